//! Templates: the taught silhouettes, resampled to `m` points and described.
//!
//! A template is made from the outer border of a part at its reference pose (angle 0): the
//! border is resampled to `m` points (eq. 4.5) and described with the neighbourhood
//! `round(k·m/n)` (DESIGN.md: the same fraction of the outline as a part's `k` of `n`).
//! [`Template::from_silhouette`] takes the largest outer border of a silhouette image (part 255,
//! rest 0; `docs/pipeline-spec.md` §9).
//!
//! Memory: `32·M + 152` bytes per template of capacity `M` on a 32-bit camera, its holes and
//! tolerance included
//! (see `vorl budget`).

use crate::contour::{trace_borders, BorderFilter, ContourStore, Point};
use crate::descriptor::describe;
use crate::error::{Error, Result};
use crate::frame::Frame;
use crate::holes::{Holes, MIN_HOLE_FRACTION};
use crate::params::Params;
use crate::pose::area_centroid;
use crate::resample::resample;

/// One taught part: `m` resampled border points, their descriptor and centroids, and the
/// sub-pixel edge the refine stage aligns.
#[derive(Debug, Clone, PartialEq)]
pub struct Template<const M: usize> {
    m: usize,
    points: [[f32; 2]; M],
    descriptor: [f32; M],
    /// The descriptor values in ascending order (for [`crate::matching::sorted_lower_bound`]).
    sorted: [f32; M],
    centroid: [f32; 2],
    area_centroid: [f32; 2],
    area: f32,
    /// Sub-pixel edge points, offsets from `area_centroid`.
    edge: [[f32; 2]; M],
    /// Unit outward normals at the edge points.
    normals: [[f32; 2]; M],
    /// The silhouette's own centroid (mean of its pixels) as an offset from `area_centroid`:
    /// where the part's position is, in template coordinates.
    position: [f32; 2],
    /// Mean distance of the edge turned by 180° about the area centroid to the edge itself,
    /// over [`Self::size`] (0 for a 2-fold symmetric part).
    half_turn: f32,
    /// The silhouette's holes, centres as offsets from `area_centroid`.
    holes: Holes,
    /// What a class taught from several examples needs beyond the parameters' limits.
    tolerance: Tolerance,
}

/// What a class taught from several examples needs beyond the parameters' verification limit
/// and scale range: the spread of its own examples, measured when it is taught (each example
/// aligned on each other one). A single-example template has [`Tolerance::NONE`]. The
/// parameters stay the floor: the limit is never lower than `Params::verify_limit`, the
/// scale range never narrower than `[scale_min, scale_max]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Factor on the verification limit (≥ 1).
    pub verify: f32,
    /// Part size over template size that the examples need: `[low, high]`.
    pub scale: [f32; 2],
}

impl Tolerance {
    /// Nothing beyond the parameters.
    pub const NONE: Tolerance = Tolerance {
        verify: 1.0,
        scale: [1.0, 1.0],
    };

    /// Whether every value is finite, the factor at least 1 and the range ordered around 1.
    pub fn is_valid(&self) -> bool {
        self.verify.is_finite()
            && self.verify >= 1.0
            && self.scale[0].is_finite()
            && self.scale[1].is_finite()
            && self.scale[0] > 0.0
            && self.scale[0] <= 1.0
            && self.scale[1] >= 1.0
    }

    /// `[lo, hi]` widened to take this tolerance's scale range in.
    pub fn scale_range(&self, lo: f32, hi: f32) -> (f32, f32) {
        (lo.min(self.scale[0]), hi.max(self.scale[1]))
    }
}

impl<const M: usize> Template<M> {
    /// An empty template (`const`, for `static` storage).
    pub const fn empty() -> Self {
        Template {
            m: 0,
            points: [[0.0; 2]; M],
            descriptor: [0.0; M],
            sorted: [0.0; M],
            centroid: [0.0; 2],
            area_centroid: [0.0; 2],
            area: 0.0,
            edge: [[0.0; 2]; M],
            normals: [[0.0; 2]; M],
            position: [0.0; 2],
            half_turn: f32::INFINITY,
            holes: Holes::new(),
            tolerance: Tolerance::NONE,
        }
    }

    /// A template from an outer border and its hole borders (for the area centroid and the
    /// template's [`Self::holes`]).
    ///
    /// # Errors
    /// [`Error::PointCounts`] when `params.m > M`, [`Error::DegenerateContour`] for a border
    /// that cannot be resampled or described.
    pub fn from_border<'a>(
        border: &[Point],
        holes: impl Iterator<Item = &'a [Point]> + Clone,
        params: &Params,
    ) -> Result<Self> {
        let m = params.m;
        if m > M || m == 0 {
            return Err(Error::PointCounts { n: params.n, m });
        }
        let mut t = Self::empty();
        t.m = m;
        resample(border, &mut t.points[..m])?;
        t.centroid = describe(&t.points[..m], params.descriptor(m), &mut t.descriptor[..m])?;
        t.sort_descriptor();
        let ac = area_centroid(border, holes.clone()).ok_or(Error::DegenerateContour { points: border.len() })?;
        t.area_centroid = ac;
        let mut a2 = 0i64;
        for (i, p) in border.iter().enumerate() {
            let q = border.get((i + 1) % border.len()).copied().unwrap_or(*p);
            a2 += p.x as i64 * q.y as i64 - q.x as i64 * p.y as i64;
        }
        t.area = a2.unsigned_abs() as f32 * 0.5;
        t.holes = Holes::from_borders(holes, MIN_HOLE_FRACTION * t.area).relative_to(ac);
        t.derive_edge(a2 < 0, |_, _| None);
        Ok(t)
    }

    /// Computes the outward normals of the resampled outline and the sub-pixel edge points:
    /// where `crossing(point, normal)` finds the edge (an offset along the normal), there;
    /// otherwise half a pixel out from the pixel-centre outline, where a binary silhouette's edge
    /// lies on average.
    fn derive_edge(&mut self, counter_clockwise_on_screen: bool, crossing: impl Fn([f32; 2], [f32; 2]) -> Option<f32>) {
        let m = self.m;
        let ac = self.area_centroid;
        for k in 0..m {
            let points = self.points.get(..m).unwrap_or(&[]);
            let Some(p) = points.get(k).copied() else { continue };
            let n = crate::refine::outward_normal(points, k, counter_clockwise_on_screen).unwrap_or([0.0, 0.0]);
            let u = crossing(p, n).unwrap_or(0.5);
            if let (Some(e), Some(nn)) = (self.edge.get_mut(k), self.normals.get_mut(k)) {
                *e = [p[0] + u * n[0] - ac[0], p[1] + u * n[1] - ac[1]];
                *nn = n;
            }
        }
        self.measure_half_turn();
    }

    /// [`Self::half_turn`] from the edge.
    fn measure_half_turn(&mut self) {
        let edge = self.edge.get(..self.m).unwrap_or(&[]);
        let size = self.size();
        if edge.is_empty() || !(size > 0.0) {
            self.half_turn = f32::INFINITY;
            return;
        }
        let outline = crate::refine::Outline::new(edge);
        let cap = size;
        let sum: f32 = edge.iter().map(|e| outline.capped_distance([-e[0], -e[1]], cap)).sum();
        self.half_turn = sum / edge.len() as f32 / size;
    }

    /// How far the outline is from 2-fold symmetric: the mean distance of its edge turned by
    /// 180° to the edge itself, over [`Self::size`]. Near 0 (elongated parts such as rods,
    /// 2-fold parts) the DP's correspondence may be half a turn off, and the recognizer aligns
    /// both ways.
    pub fn half_turn(&self) -> f32 {
        self.half_turn
    }

    /// The template's holes (the largest, each at least [`MIN_HOLE_FRACTION`] of its area),
    /// centres as offsets from [`Self::area_centroid`] ([`crate::holes`]).
    pub fn holes(&self) -> &Holes {
        &self.holes
    }

    /// Replaces the template's holes (centres as offsets from the area centroid), as stored by
    /// a template library.
    pub fn set_holes(&mut self, holes: Holes) {
        self.holes = holes;
    }

    /// What the template's class needs beyond the parameters ([`Tolerance::NONE`] unless set).
    pub fn tolerance(&self) -> Tolerance {
        self.tolerance
    }

    /// Sets the class's tolerance (as measured when a class is taught from several examples,
    /// or stored by a template library).
    ///
    /// # Errors
    /// [`Error::Corrupt`] for a tolerance that is not [`Tolerance::is_valid`].
    pub fn set_tolerance(&mut self, tolerance: Tolerance) -> Result<()> {
        if !tolerance.is_valid() {
            return Err(Error::Corrupt {
                what: "template tolerance out of range (factor ≥ 1, scale low ≤ 1 ≤ high, finite)",
            });
        }
        self.tolerance = tolerance;
        Ok(())
    }

    /// The template's size, px: the radius of the disc of its area, `√(area/π)`. Tolerances
    /// relative to a part's size ([`crate::Params::verify_relative`]) are fractions of it.
    pub fn size(&self) -> f32 {
        crate::math::sqrt(self.area.max(0.0) / core::f32::consts::PI)
    }

    /// A template from a silhouette image (part > 127): its largest outer border.
    /// `labels` (`width·height` bytes) and `store` are scratch.
    ///
    /// ```
    /// use vorl_core::{contour::ContourStore, Frame, Params, Template};
    /// let (w, h) = (40, 40);
    /// let mut px = vec![0u8; w * h];
    /// for y in 10..30 { for x in 8..32 { px[y * w + x] = 255; } }
    /// let mut labels = vec![0u8; w * h];
    /// let mut store = ContourStore::<1024, 8>::new();
    /// let t = Template::<96>::from_silhouette(&Frame::new_checked(&px[..], w, h).unwrap(), &Params::DEFAULT, &mut labels, &mut store).unwrap();
    /// assert_eq!(t.points().len(), 96);
    /// assert!((t.area_centroid()[0] - 19.5).abs() < 1e-4);
    /// ```
    ///
    /// # Errors
    /// [`Error::NoPart`] when the image has no border, plus those of [`Self::from_border`] and
    /// [`trace_borders`].
    pub fn from_silhouette<B: AsRef<[u8]>, const P: usize, const C: usize>(
        silhouette: &Frame<B>,
        params: &Params,
        labels: &mut [u8],
        store: &mut ContourStore<P, C>,
    ) -> Result<Self> {
        let (w, h) = (silhouette.width(), silhouette.height());
        let n = w * h;
        if labels.len() < n {
            return Err(Error::BufferTooSmall {
                needed: n,
                got: labels.len(),
            });
        }
        for (y, row) in labels.chunks_exact_mut(w.max(1)).take(h).enumerate() {
            for (l, &p) in row.iter_mut().zip(silhouette.row(y)) {
                *l = (p > 127) as u8;
            }
        }
        let filter = BorderFilter {
            min_points: 1,
            min_area: 0.0,
        };
        trace_borders(labels, w, h, filter, store)?;
        let best = store.largest_outer().ok_or(Error::NoPart)?;
        let holes = store.holes_of(best).map(|i| store.points(i));
        let mut t = Self::from_border(store.points(best), holes, params)?;
        // The silhouette's edge: where the bilinear image crosses half level along each normal.
        let ccw = store.contours().get(best).is_some_and(|c| c.area2 < 0);
        t.derive_edge(ccw, |p, n| silhouette_crossing(silhouette, p, n));
        // The silhouette's pixel centroid, relative to the area centroid.
        let (mut sx, mut sy, mut count) = (0.0f32, 0.0f32, 0usize);
        for y in 0..h {
            for (x, &v) in silhouette.row(y).iter().enumerate() {
                if v > 127 {
                    sx += x as f32;
                    sy += y as f32;
                    count += 1;
                }
            }
        }
        if count > 0 {
            t.position = [
                sx / count as f32 - t.area_centroid[0],
                sy / count as f32 - t.area_centroid[1],
            ];
        }
        Ok(t)
    }

    /// Sub-pixel edge points (offsets from [`Self::area_centroid`]), one per resampled point.
    pub fn edge(&self) -> &[[f32; 2]] {
        self.edge.get(..self.m).unwrap_or(&[])
    }

    /// Unit outward normals at [`Self::edge`].
    pub fn normals(&self) -> &[[f32; 2]] {
        self.normals.get(..self.m).unwrap_or(&[])
    }

    /// The part's position (the silhouette's pixel centroid) as an offset from
    /// [`Self::area_centroid`].
    pub fn position_offset(&self) -> [f32; 2] {
        self.position
    }

    /// A template from its stored parts (as [`crate::library`] reads them): the `m` resampled
    /// points, their `m` descriptor values, the points' mean `C'`, the area centroid and the area.
    ///
    /// ```
    /// use vorl_core::Template;
    /// let pts = [[0.0f32, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]];
    /// let t = Template::<8>::from_parts(pts, [1.0; 4], [2.0, 1.0], [2.0, 1.0], 8.0).unwrap();
    /// assert_eq!((t.len(), t.centroid()), (4, [2.0, 1.0]));
    /// assert!(Template::<3>::from_parts(pts, [1.0; 4], [2.0, 1.0], [2.0, 1.0], 8.0).is_err());
    /// ```
    ///
    /// # Errors
    /// [`Error::Capacity`] for more than `M` points or descriptor values,
    /// [`Error::DegenerateContour`] for fewer than 3 points, and [`Error::Corrupt`] when the
    /// counts differ or a value is not finite.
    pub fn from_parts(
        points: impl IntoIterator<Item = [f32; 2]>,
        descriptor: impl IntoIterator<Item = f32>,
        centroid: [f32; 2],
        area_centroid: [f32; 2],
        area: f32,
    ) -> Result<Self> {
        let mut t = Self::empty();
        let full = |requested| Error::Capacity {
            what: "template points M",
            capacity: M,
            requested,
        };
        let mut m = 0;
        for p in points {
            *t.points.get_mut(m).ok_or(full(m + 1))? = p;
            m += 1;
        }
        let mut count = 0;
        for c in descriptor {
            *t.descriptor.get_mut(count).ok_or(full(count + 1))? = c;
            count += 1;
        }
        if m < 3 {
            return Err(Error::DegenerateContour { points: m });
        }
        if count != m {
            return Err(Error::Corrupt {
                what: "template points and descriptor differ in length",
            });
        }
        let scalars = centroid.into_iter().chain(area_centroid).chain([area]);
        let mut values = t.points.iter().flatten().chain(&t.descriptor).copied().chain(scalars);
        if !values.all(f32::is_finite) {
            return Err(Error::Corrupt {
                what: "template value is not finite",
            });
        }
        t.m = m;
        t.sort_descriptor();
        t.centroid = centroid;
        t.area_centroid = area_centroid;
        t.area = area;
        // The edge: half a pixel out from the stored outline (no silhouette to look at here).
        let mut a2 = 0.0f32;
        for k in 0..m {
            if let (Some(a), Some(b)) = (t.points.get(k), t.points.get((k + 1) % m)) {
                a2 += a[0] * b[1] - b[0] * a[1];
            }
        }
        t.derive_edge(a2 < 0.0, |_, _| None);
        t.position = [0.0; 2];
        Ok(t)
    }

    /// Replaces the sub-pixel edge (offsets from the area centroid), its normals and the
    /// position offset, as stored by a template library.
    ///
    /// # Errors
    /// [`Error::Corrupt`] when the lengths differ from `m` or a value is not finite.
    pub fn set_edge(&mut self, edge: &[[f32; 2]], normals: &[[f32; 2]], position: [f32; 2]) -> Result<()> {
        if edge.len() != self.m || normals.len() != self.m {
            return Err(Error::Corrupt {
                what: "template edge length differs from m",
            });
        }
        if !edge
            .iter()
            .chain(normals)
            .flatten()
            .chain(&position)
            .all(|v| v.is_finite())
        {
            return Err(Error::Corrupt {
                what: "template edge value is not finite",
            });
        }
        for (d, s) in self.edge.iter_mut().zip(edge) {
            *d = *s;
        }
        for (d, s) in self.normals.iter_mut().zip(normals) {
            *d = *s;
        }
        self.position = position;
        self.measure_half_turn();
        Ok(())
    }

    /// Number of resampled points `m`.
    pub fn len(&self) -> usize {
        self.m
    }

    /// Whether the template is empty (never for one made by a constructor).
    pub fn is_empty(&self) -> bool {
        self.m == 0
    }

    /// The `m` resampled border points.
    pub fn points(&self) -> &[[f32; 2]] {
        self.points.get(..self.m).unwrap_or(&[])
    }

    /// The `m` descriptor values `c'_j`.
    pub fn descriptor(&self) -> &[f32] {
        self.descriptor.get(..self.m).unwrap_or(&[])
    }

    /// The `m` descriptor values in ascending order.
    pub fn sorted_descriptor(&self) -> &[f32] {
        self.sorted.get(..self.m).unwrap_or(&[])
    }

    /// Fills `sorted` from the first `m` descriptor values.
    fn sort_descriptor(&mut self) {
        let m = self.m.min(M);
        if let (Some(dst), Some(src)) = (self.sorted.get_mut(..m), self.descriptor.get(..m)) {
            dst.copy_from_slice(src);
            crate::matching::sort_total(dst);
        }
    }

    /// Mean of the resampled points (the `C'` of eqs. 4.1–4.2 and 6.3).
    pub fn centroid(&self) -> [f32; 2] {
        self.centroid
    }

    /// Area centroid of the silhouette (the reference position).
    pub fn area_centroid(&self) -> [f32; 2] {
        self.area_centroid
    }

    /// Polygon area of the border, px².
    pub fn area(&self) -> f32 {
        self.area
    }
}

/// Offset along `n` from `p` where the silhouette's bilinear interpolation crosses 127.5,
/// searched within ±1.5 px (the nearest crossing), or `None`.
fn silhouette_crossing<B: AsRef<[u8]>>(img: &Frame<B>, p: [f32; 2], n: [f32; 2]) -> Option<f32> {
    let sample = |u: f32| {
        let (x, y) = (p[0] + u * n[0], p[1] + u * n[1]);
        let (fx, fy) = (crate::math::floor(x), crate::math::floor(y));
        let (tx, ty) = (x - fx, y - fy);
        let at = |dx: isize, dy: isize| img.get_clamped(fx as isize + dx, fy as isize + dy) as f32;
        (at(0, 0) * (1.0 - tx) + at(1, 0) * tx) * (1.0 - ty) + (at(0, 1) * (1.0 - tx) + at(1, 1) * tx) * ty
    };
    let mut best: Option<f32> = None;
    let steps = 12;
    let step = 1.5 / steps as f32;
    let mut prev = sample(-1.5) - 127.5;
    for k in (-steps + 1)..=steps {
        let u = k as f32 * step;
        let cur = sample(u) - 127.5;
        if prev > 0.0 && cur <= 0.0 {
            let t = prev / (prev - cur);
            let c = u - step + t * step;
            if best.is_none_or(|b| c.abs() < b.abs()) {
                best = Some(c);
            }
        }
        prev = cur;
    }
    best
}
