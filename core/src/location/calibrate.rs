//! Camera to robot: where a part found in the image lies in the robot's working frame.
//!
//! The paper's section 6 ends the pipeline with "the location coordinate of that point in the
//! camera physical coordinates … as well as in the robot's working coordinates" and leaves the
//! camera-to-robot step open. `DESIGN.md` (data flow, last arrow: "camera-to-robot transform")
//! places it after the pose and the optional stereo stage. Two set-ups are covered:
//!
//! - **One camera over a flat platform**: [`Homography`], the plane-to-plane projective map from
//!   pixels to the robot's platform coordinates `(x, y)`, fitted from at least 4 pixel ↔ robot
//!   point pairs by the normalised direct linear transform (Hartley & Zisserman, *Multiple View
//!   Geometry*, algorithm 4.2). It maps a part's position and its angle.
//! - **A stereo rig** ([`crate::location::stereo`]): [`RigidTransform`], rotation and translation from the
//!   left camera's 3-D frame to the robot's, fitted from at least 3 point pairs by the Kabsch
//!   least-squares method with the reflection fix.
//!
//! Both fits return the RMS residual over their calibration points in robot units (the distance
//! between each robot point and its mapped camera point), so a bad calibration shows itself.
//!
//! ## Precision: the fits run in `f64`, the maps in `f32`
//!
//! The fits accumulate and decompose in `f64` (nalgebra, no `std`; a Cortex-M4F emulates `f64`
//! in software, which is acceptable for a calibration that runs once). The fitted matrices are
//! stored and applied in `f32`, the core's type. Measured by this module's tests (a camera
//! 700 mm above the platform, tilted 3–25°, pixels 0..640 × 0..480, a scene of ~620 mm,
//! worst error over 200 held-back points, noise-free pairs):
//!
//! | homography | 35 points, tilt 3° | 35 points, tilt 25° | 400 points, tilt 25° |
//! |---|---|---|---|
//! | DLT in `f64`, map in `f32` (this module) | 0.86e-4 mm | 1.4e-4 mm | 1.0e-4 mm |
//! | DLT in `f32`, map in `f32` | 1.3e-4 mm | 3.6e-4 mm | 4.3e-4 mm |
//! | DLT in `f64`, map in `f64` (floor of the `f32` inputs) | 1.5e-5 mm | 0.8e-5 mm | 0.3e-5 mm |
//!
//! Both meet the 1e-3 mm requirement on these scenes, the `f32` DLT with a third of the
//! margin, shrinking with tilt and point count. The deciding reason is the degeneracy check:
//! the eigenvalues of the squared 9×9 system are only good to ~1e-7 of the largest in `f32`,
//! so the DLT's singular value ratio has a rounding floor near 1e-4: with 3 of 4 points on a
//! line (no unique homography) the `f32` DLT gives σ₂/σ_max = 1.1e-4 and would pass
//! [`HOMOGRAPHY_MIN_SINGULAR_RATIO`], where `f64` gives 4e-9. The `f32` map's own rounding
//! (~1e-7 relative, the first row of the table) stays far below the requirement. Kabsch: 0.9e-4
//! mm in `f64` against 1.8e-4 mm in `f32` (1.8e-7 and 3.5e-7 of the scene); `f64` as well, for
//! the margin and one rule for both fits.
//!
//! ## Degenerate input
//!
//! Never a panic and never a NaN in a result; instead an [`Error`]:
//!
//! | input | error |
//! |---|---|
//! | fewer pairs than the fit needs (4 / 3) | [`Error::TooFewPoints`] |
//! | a non-finite coordinate | [`Error::Parameter`] (`"pixel"`, `"robot"`, `"camera"`) |
//! | coincident points, collinear points (and for the homography any set without 4 points in general position, e.g. 3 of 4 on a line) | [`Error::DegeneratePoints`] |
//! | the decomposition does not converge, or the result is not finite or maps a calibration point to infinity | [`Error::Singular`] |
//!
//! ## Time and memory
//!
//! [`Homography::fit`]: `O(n)` to accumulate the 9×9 normal matrix `AᵀA` (two rank-one updates
//! per pair), then one fixed-size 9×9 symmetric eigendecomposition (a few thousand `f64`
//! operations); no storage grows with `n`. [`RigidTransform::fit`]: `O(n)` plus one 3×3 SVD.
//! Stack, from the frame sizes of a `thumbv7em-none-eabihf` release build along the deepest
//! call path: [`Homography::fit`] about 9.2 KiB (4.7 KiB its own frame, 4.5 KiB nalgebra's
//! eigensolver), [`RigidTransform::fit`] about 3.3 KiB; both run once, at calibration, not per
//! frame. Code, if linked: about 35 KB and 40 KB of flash (mostly nalgebra's `f64`, largely
//! shared between the two). [`Homography::map`] (8 bytes of stack), [`Homography::map_angle`]
//! (40 bytes) and [`RigidTransform::map`]: constant time, `f32`. A [`Homography`] is 36 bytes,
//! a [`RigidTransform`] 48 bytes.

use nalgebra::{Matrix3, RealField, SMatrix, SVector, Vector3};

use crate::error::{Error, Result};
use crate::math;

/// Fewest point pairs a [`Homography`] needs (8 degrees of freedom, 2 equations per pair).
pub const MIN_HOMOGRAPHY_POINTS: usize = 4;

/// Fewest point pairs a [`RigidTransform`] needs (3 points not on one line).
pub const MIN_RIGID_POINTS: usize = 3;

/// The DLT's null space must be one-dimensional: the second smallest singular value of the
/// normalised `2n × 9` design matrix `A` must exceed this fraction of its largest one, or the
/// points are [`Error::DegeneratePoints`].
///
/// Four points in general position give ratios of 1e-2 and more; collinear points, coincident
/// points, or 3 of 4 points on a line give ratios at the `f64` rounding level of the squared
/// system (below 1e-7). In Hartley-normalised units (mean distance √2 from the centroid) a
/// ratio of 1e-5 means, roughly, a point that lies 1e-5 of the point spread off the line through
/// the others.
pub const HOMOGRAPHY_MIN_SINGULAR_RATIO: f64 = 1e-5;

/// The camera points of a [`RigidTransform`] fit must not lie on one line: the second largest
/// singular value of the 3×3 cross-covariance must exceed this fraction of the largest, or the
/// points are [`Error::DegeneratePoints`]. The singular values grow with the square of the
/// extent, so 1e-8 means a width across the line below 1e-4 of the length along it.
pub const RIGID_MIN_SINGULAR_RATIO: f64 = 1e-8;

/// Iteration cap of the eigen- and singular value decompositions: past it the fit is
/// [`Error::Singular`] instead of looping on.
const MAX_ITERATIONS: usize = 1000;

/// A point maps to infinity when its homogeneous weight `w` is at most this fraction of the
/// sum of the magnitudes of the terms that make it up.
const W_MIN_RELATIVE: f32 = 1e-6;

/// Whether a homogeneous weight `w` whose terms have magnitudes summing to `size` is a finite,
/// non-zero weight: `|w|` above [`W_MIN_RELATIVE`]` · size`, so the point does not map to
/// infinity (false for NaN).
fn is_finite_weight(w: f32, size: f32) -> bool {
    w.is_finite() && w.abs() > W_MIN_RELATIVE * size
}

/// Checks that every coordinate of every pair is finite.
fn check_finite<const A: usize, const B: usize>(
    pairs: &[([f32; A], [f32; B])],
    name_a: &'static str,
    name_b: &'static str,
) -> Result<()> {
    for (a, b) in pairs {
        if let Some(&value) = a.iter().find(|v| !v.is_finite()) {
            return Err(Error::Parameter { name: name_a, value });
        }
        if let Some(&value) = b.iter().find(|v| !v.is_finite()) {
            return Err(Error::Parameter { name: name_b, value });
        }
    }
    Ok(())
}

/// A value of `f64` in the fit's scalar type.
fn c<T: RealField + Copy>(v: f64) -> T {
    nalgebra::convert(v)
}

/// A value of the fit's scalar type in `f64` (exact for `f32` and `f64`).
fn to_f64<T: RealField + Copy>(v: T) -> f64 {
    nalgebra::try_convert(v).unwrap_or(f64::NAN)
}

/// Centroid and Hartley scale (`√2 /` mean distance from the centroid) of one side of the
/// pairs; `DegeneratePoints` when the points coincide (to the rounding of `T`).
fn normalisation<T: RealField + Copy>(points: impl Iterator<Item = [f32; 2]> + Clone) -> Result<(T, T, T)> {
    let (mut sx, mut sy, mut n) = (T::zero(), T::zero(), T::zero());
    for p in points.clone() {
        sx += c::<T>(p[0] as f64);
        sy += c::<T>(p[1] as f64);
        n += T::one();
    }
    let (cx, cy) = (sx / n, sy / n);
    let mut dist = T::zero();
    for p in points {
        let (dx, dy) = (c::<T>(p[0] as f64) - cx, c::<T>(p[1] as f64) - cy);
        dist += (dx * dx + dy * dy).sqrt();
    }
    let mean = dist / n;
    let size = cx.abs().max(cy.abs()).max(T::one());
    if !mean.is_finite() || mean <= T::default_epsilon() * c(64.0) * size {
        return Err(Error::DegeneratePoints);
    }
    Ok((cx, cy, c::<T>(core::f64::consts::SQRT_2) / mean))
}

/// The normalised DLT in the scalar type `T` (`f64` in [`Homography::fit`]; `f32` only in the
/// tests, to measure why not). Expects at least 4 pairs of finite points. Returns the
/// homography pixel → robot in `f64`, scaled so that `w = 1` at the pixel centroid.
fn dlt<T: RealField + Copy>(pairs: &[([f32; 2], [f32; 2])]) -> Result<[[f64; 3]; 3]> {
    let (h, ratio) = dlt_unchecked::<T>(pairs)?;
    if !ratio.is_finite() || ratio <= HOMOGRAPHY_MIN_SINGULAR_RATIO {
        return Err(Error::DegeneratePoints);
    }
    Ok(h)
}

/// [`dlt`] without the null-space check; also returns the ratio of the second smallest to the
/// largest singular value of `A` that the check uses.
fn dlt_unchecked<T: RealField + Copy>(pairs: &[([f32; 2], [f32; 2])]) -> Result<([[f64; 3]; 3], f64)> {
    let (pcx, pcy, ps) = normalisation::<T>(pairs.iter().map(|p| p.0))?;
    let (rcx, rcy, rs) = normalisation::<T>(pairs.iter().map(|p| p.1))?;
    let mut ata = SMatrix::<T, 9, 9>::zeros();
    for (px, rb) in pairs {
        let x = (c::<T>(px[0] as f64) - pcx) * ps;
        let y = (c::<T>(px[1] as f64) - pcy) * ps;
        let u = (c::<T>(rb[0] as f64) - rcx) * rs;
        let v = (c::<T>(rb[1] as f64) - rcy) * rs;
        let (o, z) = (T::one(), T::zero());
        // Rows of A for H·(x, y, 1) ∝ (u, v, 1): both cross-product equations.
        let r1 = SVector::<T, 9>::from_column_slice(&[-x, -y, -o, z, z, z, u * x, u * y, u]);
        let r2 = SVector::<T, 9>::from_column_slice(&[z, z, z, -x, -y, -o, v * x, v * y, v]);
        ata.ger(T::one(), &r1, &r1, T::one());
        ata.ger(T::one(), &r2, &r2, T::one());
    }
    if ata.iter().any(|v| !v.is_finite()) {
        return Err(Error::Singular);
    }
    let eig = ata
        .try_symmetric_eigen(T::default_epsilon(), MAX_ITERATIONS)
        .ok_or(Error::Singular)?;
    // Smallest, second smallest and largest eigenvalue of AᵀA (squared singular values of A).
    let lam = |i: usize| eig.eigenvalues.get(i).copied().unwrap_or(T::zero()).max(T::zero());
    let (mut i0, mut i1) = (0usize, 1usize);
    if lam(i1) < lam(i0) {
        core::mem::swap(&mut i0, &mut i1);
    }
    let mut largest = lam(i0).max(lam(i1));
    for i in 2..9 {
        let l = lam(i);
        largest = largest.max(l);
        if l < lam(i0) {
            i1 = i0;
            i0 = i;
        } else if l < lam(i1) {
            i1 = i;
        }
    }
    if !largest.is_finite() || largest <= T::zero() {
        return Err(Error::DegeneratePoints);
    }
    let ratio = to_f64((lam(i1) / largest).sqrt());
    let h = eig.eigenvectors.column(i0);
    let hn = Matrix3::<T>::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let (o, z) = (T::one(), T::zero());
    let tp = Matrix3::<T>::new(ps, z, -ps * pcx, z, ps, -ps * pcy, z, z, o);
    let tr_inv = Matrix3::<T>::new(o / rs, z, rcx, z, o / rs, rcy, z, z, o);
    let hm = tr_inv * hn * tp;
    let mut out = [[0.0f64; 3]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = to_f64(hm[(r, k)]);
        }
    }
    // Scale so that w = 1 at the pixel centroid (positive over the calibrated area).
    let (cx, cy) = (to_f64(pcx), to_f64(pcy));
    let w = out[2][0] * cx + out[2][1] * cy + out[2][2];
    let size = (out[2][0] * cx).abs() + (out[2][1] * cy).abs() + out[2][2].abs();
    if !w.is_finite() || w.abs() <= 1e-9 * size {
        return Err(Error::Singular);
    }
    for v in out.iter_mut().flatten() {
        *v /= w;
    }
    if out.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::Singular);
    }
    Ok((out, ratio))
}

/// A plane homography from pixels to the robot's platform coordinates `(x, y)`.
///
/// Fitted by [`Homography::fit`] from point pairs, or built from a stored matrix by
/// [`Homography::from_matrix`]. It maps a pixel `(x, y)` (image convention: x right, y down,
/// pixel centres at integer coordinates, `DESIGN.md` "Contracts") to
/// `(X, Y) = (h₀₀x + h₀₁y + h₀₂, h₁₀x + h₁₁y + h₁₂) / (h₂₀x + h₂₁y + h₂₂)`.
///
/// ## Angles and handedness
///
/// An image angle (degrees counter-clockwise *as seen on screen*, the direction
/// `(cos θ, −sin θ)` in pixel coordinates since y points down) is mapped by
/// [`Homography::map_angle`] to the robot angle: degrees counter-clockwise from the robot's +x
/// axis towards its +y axis, `atan2(ΔY, ΔX)`, in `[0, 360)`. It is the direction of the part's
/// reference axis (its template's +x axis, turned by the part's angle) on the platform.
///
/// The handedness follows from the homography, nothing is assumed: for a camera looking down on
/// the platform and a right-handed robot frame with z up, a turn counter-clockwise on screen is
/// counter-clockwise for the robot too, and the robot angle is the image angle plus a constant
/// (exactly so for an affine map, nearly so under perspective). When the image is **mirrored**
/// relative to the robot frame (a sensor or driver flip, a mirror in the light path, or a robot
/// frame whose z axis points down into the platform), the homography reverses orientation and
/// the robot angle becomes a constant *minus* the image angle; [`Homography::map_angle`] gives
/// the right value in both cases because it maps a direction vector, and
/// [`Homography::mirrored`] says which case holds.
///
/// ```
/// use vorl_core::location::calibrate::Homography;
/// // Camera straight above: 0.5 mm per pixel, image y down = robot y decreasing,
/// // pixel (0, 0) at robot (100, 300).
/// let robot = |p: [f32; 2]| [100.0 + 0.5 * p[0], 300.0 - 0.5 * p[1]];
/// let pixels = [[0.0f32, 0.0], [640.0, 0.0], [640.0, 480.0], [0.0, 480.0], [320.0, 240.0]];
/// let pairs: Vec<_> = pixels.iter().map(|&p| (p, robot(p))).collect();
/// let (h, rms) = Homography::fit(&pairs)?;
/// assert!(rms < 1e-3);
/// let [x, y] = h.map([200.0, 100.0]).unwrap();
/// assert!((x - 200.0).abs() < 1e-3 && (y - 250.0).abs() < 1e-3);
/// // 30° counter-clockwise on screen is 30° counter-clockwise for the robot.
/// let a = h.map_angle([200.0, 100.0], 30.0).unwrap();
/// assert!((a - 30.0).abs() < 1e-3);
/// assert_eq!(h.mirrored([200.0, 100.0]), Some(false));
/// # Ok::<(), vorl_core::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homography {
    h: [[f32; 3]; 3],
}

impl Homography {
    /// Fits the homography pixel → robot to `pairs` of `(pixel, robot)` points by the normalised
    /// DLT and returns it with the RMS residual in robot units (the root mean square distance
    /// between each robot point and its mapped pixel).
    ///
    /// Both point sets are moved to their centroid and scaled to a mean distance of √2 (Hartley
    /// normalisation); the `2n × 9` system `A h = 0` is accumulated as the 9×9 `AᵀA` in `f64`
    /// and `h` is the eigenvector of its smallest eigenvalue (the right singular vector of `A`
    /// for the smallest singular value); the result is scaled to `w = 1` at the pixel centroid.
    /// Least squares in the algebraic error: with noise-free pairs exact, with noisy pairs close
    /// to the geometric optimum for a well-spread point set.
    ///
    /// # Errors
    ///
    /// [`Error::TooFewPoints`] below [`MIN_HOMOGRAPHY_POINTS`]; [`Error::Parameter`] for a
    /// non-finite coordinate (`"pixel"` or `"robot"`); [`Error::DegeneratePoints`] when either
    /// side's points coincide or the DLT's null space is not one-dimensional
    /// ([`HOMOGRAPHY_MIN_SINGULAR_RATIO`]: collinear points, 3 of 4 points on a line);
    /// [`Error::Singular`] when the decomposition fails, the result is not finite, or a
    /// calibration point maps to infinity.
    pub fn fit(pairs: &[([f32; 2], [f32; 2])]) -> Result<(Homography, f32)> {
        if pairs.len() < MIN_HOMOGRAPHY_POINTS {
            return Err(Error::TooFewPoints {
                needed: MIN_HOMOGRAPHY_POINTS,
                got: pairs.len(),
            });
        }
        check_finite(pairs, "pixel", "robot")?;
        let m = dlt::<f64>(pairs)?;
        let mut h = [[0.0f32; 3]; 3];
        for (row, src) in h.iter_mut().zip(m.iter()) {
            for (v, &s) in row.iter_mut().zip(src.iter()) {
                *v = s as f32;
            }
        }
        // An entry beyond the range of f32 is a failed fit, not a bad parameter.
        let hom = Homography::from_matrix(h).map_err(|_| Error::Singular)?;
        let mut sum = 0.0f64;
        for (px, rb) in pairs {
            let [x, y] = hom.map(*px).ok_or(Error::Singular)?;
            let (dx, dy) = ((x - rb[0]) as f64, (y - rb[1]) as f64);
            sum += dx * dx + dy * dy;
        }
        let rms = (sum / pairs.len() as f64) as f32;
        let rms = math::sqrt(rms);
        if !rms.is_finite() {
            return Err(Error::Singular);
        }
        Ok((hom, rms))
    }

    /// A homography from its 3×3 matrix, row-major, pixel → robot (e.g. one stored after a
    /// calibration, from [`Homography::matrix`]).
    ///
    /// # Errors
    ///
    /// [`Error::Parameter`] (`"homography"`) for a non-finite entry; [`Error::Singular`] when
    /// the matrix's determinant is zero or not finite.
    pub fn from_matrix(h: [[f32; 3]; 3]) -> Result<Homography> {
        if let Some(&value) = h.iter().flatten().find(|v| !v.is_finite()) {
            return Err(Error::Parameter {
                name: "homography",
                value,
            });
        }
        let det = det3(&h);
        if det == 0.0 || !det.is_finite() {
            return Err(Error::Singular);
        }
        Ok(Homography { h })
    }

    /// The 3×3 matrix, row-major, pixel → robot.
    pub fn matrix(&self) -> [[f32; 3]; 3] {
        self.h
    }

    /// The homogeneous image of a pixel, `(X·w, Y·w, w)`, and the size of `w`'s terms.
    fn homogeneous(&self, p: [f32; 2]) -> ([f32; 3], f32) {
        let h = &self.h;
        let row = |r: &[f32; 3]| r[0] * p[0] + r[1] * p[1] + r[2];
        let size = (h[2][0] * p[0]).abs() + (h[2][1] * p[1]).abs() + h[2][2].abs();
        ([row(&h[0]), row(&h[1]), row(&h[2])], size)
    }

    /// The robot `(x, y)` of a pixel; `None` when the pixel maps to infinity (its homogeneous
    /// weight `w` is zero, at most 1e-6 of the size of its terms: the pixel lies on or next to
    /// the platform's horizon line) or the result is not finite (e.g. a NaN pixel).
    ///
    /// Constant time, a dozen `f32` operations.
    pub fn map(&self, p: [f32; 2]) -> Option<[f32; 2]> {
        let ([u, v, w], size) = self.homogeneous(p);
        if !is_finite_weight(w, size) {
            return None;
        }
        let out = [u / w, v / w];
        (out[0].is_finite() && out[1].is_finite()).then_some(out)
    }

    /// The robot angle of a part at pixel `at` whose image angle is `angle_deg` (degrees
    /// counter-clockwise on screen): degrees counter-clockwise from the robot's +x axis, in
    /// `[0, 360)` (see the type's documentation for the convention and mirrored images).
    ///
    /// The pixel `at` and a second pixel one unit along the angle's direction,
    /// `at + (cos θ, −sin θ)`, are mapped and the angle of the mapped vector is taken. The
    /// difference of the two mapped points is formed algebraically,
    /// `Δ = (δn·w₀ − n₀·δw) / (w₀·w₁)`, so that it does not lose digits to the cancellation of
    /// two nearly equal robot coordinates in `f32`.
    ///
    /// `None` when either pixel maps to infinity, the two lie on opposite sides of the horizon
    /// line, or the inputs are not finite.
    pub fn map_angle(&self, at: [f32; 2], angle_deg: f32) -> Option<f32> {
        if !angle_deg.is_finite() {
            return None;
        }
        let (s, c) = math::sin_cos(math::radians(angle_deg));
        let (dx, dy) = (c, -s);
        let h = &self.h;
        let ([n0u, n0v, w0], size0) = self.homogeneous(at);
        let du = h[0][0] * dx + h[0][1] * dy;
        let dv = h[1][0] * dx + h[1][1] * dy;
        let dw = h[2][0] * dx + h[2][1] * dy;
        let w1 = w0 + dw;
        let size1 = size0 + (h[2][0] * dx).abs() + (h[2][1] * dy).abs();
        if !is_finite_weight(w0, size0) || !is_finite_weight(w1, size1) {
            return None;
        }
        if (w0 > 0.0) != (w1 > 0.0) {
            return None;
        }
        // Only the direction matters: drop the positive factor 1 / (w₀·w₁).
        let ex = du * w0 - n0u * dw;
        let ey = dv * w0 - n0v * dw;
        if !ex.is_finite() || !ey.is_finite() || (ex == 0.0 && ey == 0.0) {
            return None;
        }
        Some(math::wrap_degrees(math::degrees(math::atan2(ey, ex))))
    }

    /// Whether the image is mirrored relative to the robot frame at pixel `at`: `Some(false)`
    /// when a turn counter-clockwise on screen is a turn counter-clockwise in the robot frame,
    /// `Some(true)` when it is clockwise. `None` when `at` maps to infinity.
    ///
    /// The sign of the Jacobian determinant of the map, `det H / w³`, read in pixel coordinates
    /// whose y points down: a negative determinant is the unmirrored case.
    pub fn mirrored(&self, at: [f32; 2]) -> Option<bool> {
        let ([_, _, w], size) = self.homogeneous(at);
        if !is_finite_weight(w, size) {
            return None;
        }
        let det = det3(&self.h);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        Some((det > 0.0) == (w > 0.0))
    }
}

/// Determinant of a 3×3 matrix (accumulated in `f64`, so that the small perspective entries of a
/// homography do not lose it).
fn det3(h: &[[f32; 3]; 3]) -> f64 {
    let g = |r: usize, k: usize| h.get(r).and_then(|row| row.get(k)).copied().unwrap_or(0.0) as f64;
    g(0, 0) * (g(1, 1) * g(2, 2) - g(1, 2) * g(2, 1)) - g(0, 1) * (g(1, 0) * g(2, 2) - g(1, 2) * g(2, 0))
        + g(0, 2) * (g(1, 0) * g(2, 1) - g(1, 1) * g(2, 0))
}

/// The Kabsch fit in the scalar type `T` (`f64` in [`RigidTransform::fit`]; `f32` only in the
/// tests). Expects at least 3 pairs of finite points. Returns rotation and translation in `f64`.
fn kabsch<T: RealField + Copy>(pairs: &[([f32; 3], [f32; 3])]) -> Result<([[f64; 3]; 3], [f64; 3])> {
    let v = |p: &[f32; 3]| Vector3::<T>::new(c(p[0] as f64), c(p[1] as f64), c(p[2] as f64));
    let mut n = T::zero();
    let (mut pc, mut qc) = (Vector3::<T>::zeros(), Vector3::<T>::zeros());
    for (p, q) in pairs {
        pc += v(p);
        qc += v(q);
        n += T::one();
    }
    pc /= n;
    qc /= n;
    let mut cov = Matrix3::<T>::zeros();
    let (mut spread_p, mut spread_q) = (T::zero(), T::zero());
    for (p, q) in pairs {
        let (dp, dq) = (v(p) - pc, v(q) - qc);
        cov.ger(T::one(), &dp, &dq, T::one());
        spread_p += dp.norm_squared();
        spread_q += dq.norm_squared();
    }
    // Coincident points (to the rounding of T) on either side.
    let tiny = T::default_epsilon() * c(64.0);
    let size_p = pc.amax().max(T::one());
    let size_q = qc.amax().max(T::one());
    let rms_p = (spread_p / n).sqrt();
    let rms_q = (spread_q / n).sqrt();
    if !rms_p.is_finite() || !rms_q.is_finite() || rms_p <= tiny * size_p || rms_q <= tiny * size_q {
        return Err(Error::DegeneratePoints);
    }
    if cov.iter().any(|x| !x.is_finite()) {
        return Err(Error::Singular);
    }
    let svd = cov
        .try_svd_unordered(true, true, T::default_epsilon(), MAX_ITERATIONS)
        .ok_or(Error::Singular)?;
    let (u, v_t) = match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => (u, v_t),
        _ => return Err(Error::Singular),
    };
    let s = |i: usize| svd.singular_values.get(i).copied().unwrap_or(T::zero()).abs();
    // Order the singular values: largest, middle, smallest.
    let mut idx = [0usize, 1, 2];
    for _ in 0..2 {
        for k in 0..2 {
            if s(idx[k]) < s(idx[k + 1]) {
                idx.swap(k, k + 1);
            }
        }
    }
    let [i_max, i_mid, i_min] = idx;
    let largest = s(i_max);
    if !largest.is_finite() || largest <= T::zero() {
        return Err(Error::DegeneratePoints);
    }
    let ratio = to_f64(s(i_mid) / largest);
    if !ratio.is_finite() || ratio <= RIGID_MIN_SINGULAR_RATIO {
        return Err(Error::DegeneratePoints);
    }
    // R = V·D·Uᵀ with D = diag(1, 1, d) on the smallest singular value, d = sign det(V·Uᵀ):
    // the reflection fix (coplanar points, or noise, can make V·Uᵀ a reflection).
    let vm = v_t.transpose();
    let d = if (vm * u.transpose()).determinant() < T::zero() {
        -T::one()
    } else {
        T::one()
    };
    let mut dm = Matrix3::<T>::identity();
    dm[(i_min, i_min)] = d;
    let r = vm * dm * u.transpose();
    let t = qc - r * pc;
    let mut rot = [[0.0f64; 3]; 3];
    for (i, row) in rot.iter_mut().enumerate() {
        for (k, x) in row.iter_mut().enumerate() {
            *x = to_f64(r[(i, k)]);
        }
    }
    let tr = [to_f64(t[0]), to_f64(t[1]), to_f64(t[2])];
    if rot.iter().flatten().chain(tr.iter()).any(|x| !x.is_finite()) {
        return Err(Error::Singular);
    }
    Ok((rot, tr))
}

/// A rigid transform (rotation and translation, no scale, no reflection) from the left stereo
/// camera's 3-D frame to the robot's frame.
///
/// The camera frame is the one of [`crate::location::stereo::StereoRig::point`]: millimetres, x right,
/// y down, z forward along the optical axis, origin at the left camera's centre. The robot
/// frame is whatever frame the robot points were given in (normally right-handed, z up). Maps
/// `p ↦ R·p + t`.
///
/// ```
/// use vorl_core::location::calibrate::RigidTransform;
/// // Camera 800 mm above the platform looking straight down: camera x = robot x,
/// // camera y = −robot y, camera z = −robot z; the camera centre at robot (250, 150, 800).
/// let robot = |p: [f32; 3]| [250.0 + p[0], 150.0 - p[1], 800.0 - p[2]];
/// let cam = [[0.0f32, 0.0, 800.0], [100.0, 0.0, 790.0], [0.0, 80.0, 810.0], [-50.0, -60.0, 780.0]];
/// let pairs: Vec<_> = cam.iter().map(|&p| (p, robot(p))).collect();
/// let (t, rms) = RigidTransform::fit(&pairs)?;
/// assert!(rms < 1e-3);
/// let [x, y, z] = t.map([10.0, 20.0, 795.0]);
/// assert!((x - 260.0).abs() < 1e-3 && (y - 130.0).abs() < 1e-3 && (z - 5.0).abs() < 1e-3);
/// # Ok::<(), vorl_core::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidTransform {
    r: [[f32; 3]; 3],
    t: [f32; 3],
}

impl RigidTransform {
    /// Fits the rigid transform camera → robot to `pairs` of `(camera, robot)` points by least
    /// squares (Kabsch: SVD of the 3×3 cross-covariance of the centred points, with the
    /// reflection fix) and returns it with the RMS residual in robot units (root mean square
    /// distance between each robot point and its mapped camera point).
    ///
    /// Coplanar points (3 or more, not on a line) are enough: the reflection fix picks the
    /// proper rotation.
    ///
    /// # Errors
    ///
    /// [`Error::TooFewPoints`] below [`MIN_RIGID_POINTS`]; [`Error::Parameter`] for a non-finite
    /// coordinate (`"camera"` or `"robot"`); [`Error::DegeneratePoints`] when either side's
    /// points coincide or the points lie on one line ([`RIGID_MIN_SINGULAR_RATIO`]);
    /// [`Error::Singular`] when the SVD fails or the result is not finite.
    pub fn fit(pairs: &[([f32; 3], [f32; 3])]) -> Result<(RigidTransform, f32)> {
        if pairs.len() < MIN_RIGID_POINTS {
            return Err(Error::TooFewPoints {
                needed: MIN_RIGID_POINTS,
                got: pairs.len(),
            });
        }
        check_finite(pairs, "camera", "robot")?;
        let (rot, tr) = kabsch::<f64>(pairs)?;
        let mut r = [[0.0f32; 3]; 3];
        for (row, src) in r.iter_mut().zip(rot.iter()) {
            for (x, &s) in row.iter_mut().zip(src.iter()) {
                *x = s as f32;
            }
        }
        let t = [tr[0] as f32, tr[1] as f32, tr[2] as f32];
        let rt = RigidTransform { r, t };
        let mut sum = 0.0f64;
        for (p, q) in pairs {
            let m = rt.map(*p);
            for (a, b) in m.iter().zip(q.iter()) {
                let d = (a - b) as f64;
                sum += d * d;
            }
        }
        let rms = math::sqrt((sum / pairs.len() as f64) as f32);
        if !rms.is_finite() {
            return Err(Error::Singular);
        }
        Ok((rt, rms))
    }

    /// A rigid transform from a rotation matrix (row-major) and a translation, e.g. stored after
    /// a calibration ([`RigidTransform::rotation`], [`RigidTransform::translation`]).
    ///
    /// # Errors
    ///
    /// [`Error::Parameter`] with name `"rotation"` or `"translation"` for a non-finite entry,
    /// and `"rotation"` (value: the largest deviation of `RᵀR` from the identity, or the
    /// determinant) when the matrix is not a proper rotation to within 1e-4.
    pub fn from_parts(rotation: [[f32; 3]; 3], translation: [f32; 3]) -> Result<RigidTransform> {
        if let Some(&value) = rotation.iter().flatten().find(|v| !v.is_finite()) {
            return Err(Error::Parameter {
                name: "rotation",
                value,
            });
        }
        if let Some(&value) = translation.iter().find(|v| !v.is_finite()) {
            return Err(Error::Parameter {
                name: "translation",
                value,
            });
        }
        let mut worst = 0.0f32;
        for i in 0..3 {
            for k in 0..3 {
                let dot: f32 = rotation.iter().map(|row| row[i] * row[k]).sum();
                let want = if i == k { 1.0 } else { 0.0 };
                worst = worst.max((dot - want).abs());
            }
        }
        if worst > 1e-4 {
            return Err(Error::Parameter {
                name: "rotation",
                value: worst,
            });
        }
        let det = det3(&rotation) as f32;
        if det < 0.0 {
            return Err(Error::Parameter {
                name: "rotation",
                value: det,
            });
        }
        Ok(RigidTransform {
            r: rotation,
            t: translation,
        })
    }

    /// The rotation matrix, row-major.
    pub fn rotation(&self) -> [[f32; 3]; 3] {
        self.r
    }

    /// The translation (robot units): where the camera frame's origin lies in the robot frame.
    pub fn translation(&self) -> [f32; 3] {
        self.t
    }

    /// The robot point of a camera point, `R·p + t`. Constant time, 18 `f32` operations.
    pub fn map(&self, p: [f32; 3]) -> [f32; 3] {
        let row = |r: &[f32; 3], t: f32| r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + t;
        [
            row(&self.r[0], self.t[0]),
            row(&self.r[1], self.t[1]),
            row(&self.r[2], self.t[2]),
        ]
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// Tiny deterministic PRNG (SplitMix64).
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [0, 1).
        fn uniform(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Standard normal, approximately: Irwin–Hall sum of 12 uniforms minus 6.
        fn gauss(&mut self) -> f64 {
            (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
        }
    }

    /// A tilted pinhole camera over the platform z = 0 of a right-handed robot frame (z up):
    /// the homography robot (x, y) → pixel, in f64, and its inverse pixel → robot.
    struct Scene {
        /// robot → pixel
        g: [[f64; 3]; 3],
        /// pixel → robot
        h: [[f64; 3]; 3],
    }

    fn mul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let mut o = [[0.0; 3]; 3];
        for i in 0..3 {
            for k in 0..3 {
                o[i][k] = (0..3).map(|j| a[i][j] * b[j][k]).sum();
            }
        }
        o
    }

    fn apply(h: &[[f64; 3]; 3], p: [f64; 2]) -> [f64; 2] {
        let w = h[2][0] * p[0] + h[2][1] * p[1] + h[2][2];
        [
            (h[0][0] * p[0] + h[0][1] * p[1] + h[0][2]) / w,
            (h[1][0] * p[0] + h[1][1] * p[1] + h[1][2]) / w,
        ]
    }

    fn inv3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let na = Matrix3::<f64>::new(
            m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
        );
        let i = na.try_inverse().unwrap();
        let mut o = [[0.0; 3]; 3];
        for r in 0..3 {
            for k in 0..3 {
                o[r][k] = i[(r, k)];
            }
        }
        o
    }

    fn rot(axis: usize, deg: f64) -> [[f64; 3]; 3] {
        let (s, c) = deg.to_radians().sin_cos();
        match axis {
            0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
            1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
            _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        }
    }

    /// Camera ~700 mm above the platform centre (robot (400, 250)), looking down, tilted by a few
    /// degrees, f = 800 px, principal point (320, 240): the platform's ~500 × 400 mm fills the
    /// 640 × 480 image. `mirror` flips the robot y axis (a left-handed robot frame seen from
    /// above, i.e. a mirrored image).
    fn scene(mirror: bool) -> Scene {
        scene_tilted(mirror, 3.0, -4.0)
    }

    /// As [`scene`], tilted by `tilt_x` and `tilt_y` degrees about the camera's axes.
    fn scene_tilted(mirror: bool, tilt_x: f64, tilt_y: f64) -> Scene {
        let f = 800.0;
        let k = [[f, 0.0, 320.0], [0.0, f, 240.0], [0.0, 0.0, 1.0]];
        // Camera axes in robot coordinates: looking down (camera z = −robot z), camera x =
        // robot x, camera y = −robot y; then turned about z by 20° and tilted a little.
        let base = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]; // robot → camera
        let r = mul3(&rot(0, tilt_x), &mul3(&rot(1, tilt_y), &mul3(&rot(2, 20.0), &base)));
        let centre = [400.0, 250.0, 700.0];
        // t = −R·centre; plane z = 0: pixel ∝ K·[r1 r2 t]·(x, y, 1).
        let t: Vec<f64> = (0..3)
            .map(|i| -(0..3).map(|j| r[i][j] * centre[j]).sum::<f64>())
            .collect();
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            m[i] = [r[i][0], r[i][1], t[i]];
        }
        let mut g = mul3(&k, &m);
        if mirror {
            // robot y' = −y: pixel = g(x, −y')
            for row in g.iter_mut() {
                row[1] = -row[1];
            }
        }
        Scene { h: inv3(&g), g }
    }

    /// `count` random robot points on the visible platform and their pixels (both f32, pixels
    /// in 0..640 × 0..480).
    fn points(s: &Scene, rng: &mut Rng, count: usize) -> Vec<([f32; 2], [f32; 2])> {
        let mut out = Vec::new();
        while out.len() < count {
            let px = [rng.uniform() * 640.0, rng.uniform() * 480.0];
            let rb = apply(&s.h, px);
            // Pixel from the f32 robot point, so the pair is exact up to the pixel's rounding.
            let rb32 = [rb[0] as f32, rb[1] as f32];
            let p = apply(&s.g, [rb32[0] as f64, rb32[1] as f64]);
            out.push(([p[0] as f32, p[1] as f32], rb32));
        }
        out
    }

    /// A 7 × 5 grid of calibration points over the image, robot points rounded to f32 first.
    fn grid(s: &Scene) -> Vec<([f32; 2], [f32; 2])> {
        let mut out = Vec::new();
        for i in 0..7 {
            for j in 0..5 {
                let px = [20.0 + 100.0 * i as f64, 20.0 + 110.0 * j as f64];
                let rb = apply(&s.h, px);
                let rb32 = [rb[0] as f32, rb[1] as f32];
                let p = apply(&s.g, [rb32[0] as f64, rb32[1] as f64]);
                out.push(([p[0] as f32, p[1] as f32], rb32));
            }
        }
        out
    }

    /// Largest distance between mapped held-back pixels and their robot points, in f64 truth.
    fn held_back_error(h: &Homography, s: &Scene, held: &[([f32; 2], [f32; 2])]) -> f64 {
        held.iter()
            .map(|(p, _)| {
                let truth = apply(&s.h, [p[0] as f64, p[1] as f64]);
                let m = h.map(*p).unwrap();
                (m[0] as f64 - truth[0]).hypot(m[1] as f64 - truth[1])
            })
            .fold(0.0, f64::max)
    }

    fn extent(pairs: &[([f32; 2], [f32; 2])]) -> f64 {
        let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
        for (_, r) in pairs {
            for k in 0..2 {
                lo[k] = lo[k].min(r[k] as f64);
                hi[k] = hi[k].max(r[k] as f64);
            }
        }
        (hi[0] - lo[0]).max(hi[1] - lo[1])
    }

    fn hom_from(m: [[f64; 3]; 3]) -> Homography {
        let mut h = [[0.0f32; 3]; 3];
        for i in 0..3 {
            for k in 0..3 {
                h[i][k] = m[i][k] as f32;
            }
        }
        Homography::from_matrix(h).unwrap()
    }

    #[test]
    fn homography_noise_free_held_back() {
        let s = scene(false);
        let mut rng = Rng(1);
        let cal = grid(&s);
        let held = points(&s, &mut rng, 200);
        let (h, rms) = Homography::fit(&cal).unwrap();
        let err = held_back_error(&h, &s, &held);
        let ext = extent(&held);
        std::println!(
            "noise-free: rms {rms:.3e} mm, held-back max {err:.3e} mm, extent {ext:.0} mm, relative {:.2e}",
            err / ext
        );
        assert!(ext > 400.0 && ext < 700.0, "{ext}");
        assert!(rms < 1e-3, "{rms}");
        assert!(err < 1e-3, "{err}");
        assert!(err / ext < 1e-6, "{}", err / ext);
        // Exactly 4 points (the corners of the image) also give the map back.
        let corners: Vec<_> = [[0.0, 0.0], [640.0, 0.0], [640.0, 480.0], [0.0, 480.0]]
            .iter()
            .map(|&p: &[f64; 2]| {
                let r = apply(&s.h, p);
                ([p[0] as f32, p[1] as f32], [r[0] as f32, r[1] as f32])
            })
            .collect();
        let (h4, _) = Homography::fit(&corners).unwrap();
        let err4 = held_back_error(&h4, &s, &held);
        assert!(err4 / ext < 1e-6, "{err4}");
    }

    /// Why the DLT runs in f64 (the table in the module documentation): the same normalised DLT
    /// in f32 (measurement only) maps noise-free held-back points nearly as well, but its
    /// singular value ratio has a rounding floor near 1e-4, so it cannot tell 3 of 4 collinear
    /// points from 4 good ones at [`HOMOGRAPHY_MIN_SINGULAR_RATIO`].
    #[test]
    fn homography_f32_versus_f64() {
        let mut rng = Rng(2);
        for (tilt_x, tilt_y, random) in [(3.0, -4.0, 0usize), (25.0, -10.0, 0), (25.0, -10.0, 400)] {
            let s = scene_tilted(false, tilt_x, tilt_y);
            let cal = if random > 0 {
                points(&s, &mut rng, random)
            } else {
                grid(&s)
            };
            let held = points(&s, &mut rng, 200);
            let m = dlt::<f64>(&cal).unwrap();
            let e64 = held_back_error(&hom_from(m), &s, &held);
            let e32 = held_back_error(&hom_from(dlt::<f32>(&cal).unwrap()), &s, &held);
            // The f64 fit applied in f64: the floor set by the f32 inputs alone.
            let e_all64 = held
                .iter()
                .map(|(p, _)| {
                    let truth = apply(&s.h, [p[0] as f64, p[1] as f64]);
                    let q = apply(&m, [p[0] as f64, p[1] as f64]);
                    (q[0] - truth[0]).hypot(q[1] - truth[1])
                })
                .fold(0.0, f64::max);
            std::println!(
                "tilt {tilt_x}°/{tilt_y}°, {} points: held-back max error: DLT f32 {e32:.3e} mm, \
                 DLT f64 + map f32 {e64:.3e} mm, all f64 {e_all64:.3e} mm",
                cal.len()
            );
            assert!(e64 < 1e-3, "{e64}");
        }
        // Degeneracy: 4 collinear points.
        let s = scene(false);
        let line: Vec<_> = (0..4)
            .map(|i| {
                let p = [50.0 + 70.0 * i as f64, 60.0 + 45.0 * i as f64];
                let r = apply(&s.h, p);
                ([p[0] as f32, p[1] as f32], [r[0] as f32, r[1] as f32])
            })
            .collect();
        assert_eq!(dlt::<f64>(&line), Err(Error::DegeneratePoints));
        let g = grid(&s);
        let mut three = line[..3].to_vec();
        three.push(g[4]);
        let good: Vec<_> = [0, 4, 30, 34].iter().map(|&i| g[i]).collect();
        for (name, set, degenerate) in [
            ("4 collinear", &line, true),
            ("3 of 4 collinear", &three, true),
            ("4 corners", &good, false),
        ] {
            let r64 = dlt_unchecked::<f64>(set).unwrap().1;
            let r32 = dlt_unchecked::<f32>(set).unwrap().1;
            std::println!("{name}: σ₂/σ_max f64 {r64:.2e}, f32 {r32:.2e}");
            if degenerate {
                assert!(r64 < HOMOGRAPHY_MIN_SINGULAR_RATIO / 100.0, "{name}: {r64}");
            } else {
                assert!(r64 > 0.1, "{name}: {r64}");
            }
        }
    }

    #[test]
    fn homography_with_pixel_noise() {
        let s = scene(false);
        let mut rng = Rng(3);
        let mut cal = grid(&s);
        let sigma = 0.5f64;
        for (p, _) in cal.iter_mut() {
            p[0] += (sigma * rng.gauss()) as f32;
            p[1] += (sigma * rng.gauss()) as f32;
        }
        let held = points(&s, &mut rng, 200);
        let (h, rms) = Homography::fit(&cal).unwrap();
        // mm per pixel at the platform centre, from the true map.
        let c = apply(&s.h, [320.0, 240.0]);
        let c1 = apply(&s.h, [321.0, 240.0]);
        let mm_per_px = (c1[0] - c[0]).hypot(c1[1] - c[1]);
        // Residual of a 2-D point after an 8-parameter fit to n points: σ·√(2·(1 − 4/n)).
        let n = cal.len() as f64;
        let expected = sigma * mm_per_px * (2.0 * (1.0 - 4.0 / n)).sqrt();
        let err = held_back_error(&h, &s, &held);
        let mean_err = held
            .iter()
            .map(|(p, _)| {
                let truth = apply(&s.h, [p[0] as f64, p[1] as f64]);
                let m = h.map(*p).unwrap();
                (m[0] as f64 - truth[0]).hypot(m[1] as f64 - truth[1])
            })
            .sum::<f64>()
            / held.len() as f64;
        std::println!(
            "0.5 px noise: {mm_per_px:.3} mm/px, rms {rms:.3} mm (expected ≈ {expected:.3}), held-back mean {mean_err:.3} mm, max {err:.3} mm"
        );
        let rms = rms as f64;
        assert!(rms > 0.6 * expected && rms < 1.5 * expected, "{rms} vs {expected}");
        // The fitted map is better than one noisy point: averaged over 35 points.
        assert!(mean_err < sigma * mm_per_px, "{mean_err}");
        assert!(err < 2.0 * sigma * mm_per_px, "{err}");
    }

    #[test]
    fn homography_angle_and_handedness() {
        for mirror in [false, true] {
            let s = scene(mirror);
            let (h, _) = Homography::fit(&grid(&s)).unwrap();
            let at = [300.0f32, 200.0];
            assert_eq!(h.mirrored(at), Some(mirror));
            let a0 = h.map_angle(at, 0.0).unwrap();
            for theta in [10.0f32, 45.0, 90.0, 180.0, 271.0] {
                let a = h.map_angle(at, theta).unwrap();
                // True direction: map the point and one a pixel away along θ in f64.
                let (sn, cs) = (theta as f64).to_radians().sin_cos();
                let p0 = apply(&s.h, [at[0] as f64, at[1] as f64]);
                let p1 = apply(&s.h, [at[0] as f64 + cs, at[1] as f64 - sn]);
                let want = (p1[1] - p0[1]).atan2(p1[0] - p0[0]).to_degrees().rem_euclid(360.0);
                let diff = ((a as f64 - want + 540.0).rem_euclid(360.0) - 180.0).abs();
                assert!(diff < 2e-3, "mirror {mirror} θ {theta}: {a} vs {want}");
                // The turn on screen shows as the same turn (or its mirror) for the robot, up to
                // the small distortion of the perspective.
                let turn = ((a - a0) as f64).rem_euclid(360.0);
                let want_turn = if mirror {
                    (-theta as f64).rem_euclid(360.0)
                } else {
                    theta as f64
                };
                let d = ((turn - want_turn + 540.0).rem_euclid(360.0) - 180.0).abs();
                assert!(d < 2.0, "mirror {mirror} θ {theta}: turn {turn} vs {want_turn}");
            }
        }
    }

    #[test]
    fn homography_map_to_infinity_and_non_finite() {
        // (x, y) ↦ (1, y) / x: the column x = 0 is the horizon.
        let h = Homography::from_matrix([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]).unwrap();
        assert_eq!(h.map([0.0, 5.0]), None);
        assert!(h.map([2.0, 4.0]).is_some());
        assert_eq!(h.map([f32::NAN, 1.0]), None);
        assert_eq!(h.map_angle([0.0, 5.0], 0.0), None);
        // Stepping across the horizon.
        assert_eq!(h.map_angle([0.5, 5.0], 180.0), None);
        assert_eq!(h.map_angle([2.0, 5.0], f32::NAN), None);
        assert_eq!(h.mirrored([0.0, 5.0]), None);
        assert_eq!(
            Homography::from_matrix([[1.0, 0.0, 0.0], [0.0, f32::INFINITY, 0.0], [0.0, 0.0, 1.0]]),
            Err(Error::Parameter {
                name: "homography",
                value: f32::INFINITY
            })
        );
        assert_eq!(
            Homography::from_matrix([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 1.0]]),
            Err(Error::Singular)
        );
    }

    #[test]
    fn homography_degenerate_inputs() {
        let s = scene(false);
        let cal = grid(&s);
        assert_eq!(
            Homography::fit(&cal[..3]),
            Err(Error::TooFewPoints { needed: 4, got: 3 })
        );
        assert_eq!(Homography::fit(&[]), Err(Error::TooFewPoints { needed: 4, got: 0 }));
        // 4 (and 7) collinear points: along a line in both images.
        let line: Vec<_> = (0..7)
            .map(|i| {
                let p = [50.0 + 70.0 * i as f64, 60.0 + 45.0 * i as f64];
                let r = apply(&s.h, p);
                ([p[0] as f32, p[1] as f32], [r[0] as f32, r[1] as f32])
            })
            .collect();
        assert_eq!(Homography::fit(&line[..4]), Err(Error::DegeneratePoints));
        assert_eq!(Homography::fit(&line), Err(Error::DegeneratePoints));
        // 3 of 4 on a line.
        let mut three = line[..3].to_vec();
        three.push(cal[4]);
        assert_eq!(Homography::fit(&three), Err(Error::DegeneratePoints));
        // … but a fifth point off the line makes it well posed.
        three.push(cal[30]);
        assert!(Homography::fit(&three).is_ok());
        // Coincident points, pixel side and robot side.
        let same = [cal[7]; 6];
        assert_eq!(Homography::fit(&same), Err(Error::DegeneratePoints));
        let mut robot_same = cal.clone();
        for p in robot_same.iter_mut() {
            p.1 = [12.5, -3.0];
        }
        assert_eq!(Homography::fit(&robot_same), Err(Error::DegeneratePoints));
        // Two distinct points, each repeated.
        let two = [cal[0], cal[0], cal[20], cal[20], cal[20]];
        assert_eq!(Homography::fit(&two), Err(Error::DegeneratePoints));
        // Non-finite input.
        let mut bad = cal.clone();
        bad[5].0[1] = f32::NAN;
        assert!(matches!(Homography::fit(&bad), Err(Error::Parameter { name: "pixel", value }) if value.is_nan()));
        let mut bad = cal.clone();
        bad[9].1[0] = f32::NEG_INFINITY;
        assert_eq!(
            Homography::fit(&bad),
            Err(Error::Parameter {
                name: "robot",
                value: f32::NEG_INFINITY
            })
        );
        // Huge but finite coordinates: an error or a finite result, never NaN.
        let mut huge = cal.clone();
        huge[3].0 = [f32::MAX, f32::MAX];
        if let Ok((h, rms)) = Homography::fit(&huge) {
            assert!(rms.is_finite() && h.matrix().iter().flatten().all(|v| v.is_finite()));
        }
    }

    /// A rotation (from three axis turns) and a translation far from the origin.
    fn rigid_truth() -> ([[f64; 3]; 3], [f64; 3]) {
        (
            mul3(&rot(2, 33.0), &mul3(&rot(1, -12.0), &rot(0, 171.0))),
            [420.0, -180.0, 915.0],
        )
    }

    fn rigid_apply(r: &[[f64; 3]; 3], t: &[f64; 3], p: [f64; 3]) -> [f64; 3] {
        let mut o = [0.0; 3];
        for i in 0..3 {
            o[i] = (0..3).map(|j| r[i][j] * p[j]).sum::<f64>() + t[i];
        }
        o
    }

    /// Camera points in a ~500 mm box in front of the camera and their robot points (f32).
    fn rigid_points(rng: &mut Rng, count: usize) -> Vec<([f32; 3], [f32; 3])> {
        let (r, t) = rigid_truth();
        (0..count)
            .map(|_| {
                let p = [
                    (rng.uniform() - 0.5) * 500.0,
                    (rng.uniform() - 0.5) * 400.0,
                    600.0 + rng.uniform() * 300.0,
                ];
                let p32 = [p[0] as f32, p[1] as f32, p[2] as f32];
                let q = rigid_apply(&r, &t, [p32[0] as f64, p32[1] as f64, p32[2] as f64]);
                (p32, [q[0] as f32, q[1] as f32, q[2] as f32])
            })
            .collect()
    }

    fn rigid_held_error(rt: &RigidTransform, held: &[([f32; 3], [f32; 3])]) -> f64 {
        let (r, t) = rigid_truth();
        held.iter()
            .map(|(p, _)| {
                let truth = rigid_apply(&r, &t, [p[0] as f64, p[1] as f64, p[2] as f64]);
                let m = rt.map(*p);
                (0..3).map(|k| (m[k] as f64 - truth[k]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn rigid_noise_free_held_back() {
        let mut rng = Rng(4);
        let cal = rigid_points(&mut rng, 12);
        let held = rigid_points(&mut rng, 200);
        let (rt, rms) = RigidTransform::fit(&cal).unwrap();
        let err = rigid_held_error(&rt, &held);
        // Scene extent: the largest side of the camera points' bounding box.
        let ext = (0..3)
            .map(|k| {
                let v = held.iter().map(|p| p.0[k] as f64);
                v.clone().fold(f64::MIN, f64::max) - v.fold(f64::MAX, f64::min)
            })
            .fold(0.0, f64::max);
        std::println!(
            "rigid noise-free: rms {rms:.3e}, held-back max {err:.3e} mm, relative {:.2e}",
            err / ext
        );
        assert!(rms < 1e-3);
        assert!(err / ext < 1e-6, "{}", err / ext);
        // Three points suffice (coplanar: the reflection fix picks the rotation).
        let (rt3, _) = RigidTransform::fit(&cal[..3]).unwrap();
        assert!(rigid_held_error(&rt3, &held) / ext < 1e-6);
        let r = rt.rotation();
        assert!(det3(&r) > 0.999 && det3(&r) < 1.001);
        // f32 Kabsch for comparison (measurement only).
        let (r32, t32) = kabsch::<f32>(&cal).unwrap();
        let conv = |m: [[f64; 3]; 3]| m.map(|row| row.map(|v| v as f32));
        let rt32 = RigidTransform::from_parts(conv(r32), t32.map(|v| v as f32)).unwrap();
        std::println!(
            "rigid Kabsch in f32: held-back max {:.3e} mm",
            rigid_held_error(&rt32, &held)
        );
    }

    #[test]
    fn rigid_round_trip_parts_and_noise() {
        let mut rng = Rng(5);
        let mut cal = rigid_points(&mut rng, 20);
        let sigma = 0.5f64;
        for (_, q) in cal.iter_mut() {
            for v in q.iter_mut() {
                *v += (sigma * rng.gauss()) as f32;
            }
        }
        let (rt, rms) = RigidTransform::fit(&cal).unwrap();
        // 3-D residual after a 6-parameter fit: σ·√(3 − 6/n).
        let expected = sigma * (3.0 - 6.0 / cal.len() as f64).sqrt();
        std::println!("rigid 0.5 mm noise: rms {rms:.3} (expected ≈ {expected:.3})");
        assert!((rms as f64) > 0.6 * expected && (rms as f64) < 1.5 * expected);
        let again = RigidTransform::from_parts(rt.rotation(), rt.translation()).unwrap();
        assert_eq!(again, rt);
        assert!(matches!(
            RigidTransform::from_parts([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]], [0.0; 3]),
            Err(Error::Parameter { name: "rotation", .. })
        ));
        assert!(matches!(
            RigidTransform::from_parts([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]),
            Err(Error::Parameter { name: "rotation", .. })
        ));
        assert!(matches!(
            RigidTransform::from_parts(
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                [0.0, f32::NAN, 0.0]
            ),
            Err(Error::Parameter {
                name: "translation",
                ..
            })
        ));
    }

    #[test]
    fn rigid_degenerate_inputs() {
        let mut rng = Rng(6);
        let cal = rigid_points(&mut rng, 10);
        assert_eq!(
            RigidTransform::fit(&cal[..2]),
            Err(Error::TooFewPoints { needed: 3, got: 2 })
        );
        // Collinear: points along one line in the camera frame (and its image).
        let (r, t) = rigid_truth();
        let line: Vec<_> = (0..5)
            .map(|i| {
                let p = [10.0 + 40.0 * i as f64, -20.0 + 15.0 * i as f64, 700.0 + 25.0 * i as f64];
                let p32 = p.map(|v| v as f32);
                let q = rigid_apply(&r, &t, p32.map(|v| v as f64));
                (p32, q.map(|v| v as f32))
            })
            .collect();
        assert_eq!(RigidTransform::fit(&line[..3]), Err(Error::DegeneratePoints));
        assert_eq!(RigidTransform::fit(&line), Err(Error::DegeneratePoints));
        // Coincident.
        assert_eq!(RigidTransform::fit(&[cal[1]; 5]), Err(Error::DegeneratePoints));
        let mut robot_same = cal.clone();
        for p in robot_same.iter_mut() {
            p.1 = [1.0, 2.0, 3.0];
        }
        assert_eq!(RigidTransform::fit(&robot_same), Err(Error::DegeneratePoints));
        // Two distinct points, repeated: collinear.
        assert_eq!(
            RigidTransform::fit(&[cal[0], cal[1], cal[0], cal[1]]),
            Err(Error::DegeneratePoints)
        );
        // Non-finite.
        let mut bad = cal.clone();
        bad[2].0[2] = f32::NAN;
        assert!(matches!(RigidTransform::fit(&bad), Err(Error::Parameter { name: "camera", value }) if value.is_nan()));
        let mut bad = cal.clone();
        bad[0].1[1] = f32::INFINITY;
        assert_eq!(
            RigidTransform::fit(&bad),
            Err(Error::Parameter {
                name: "robot",
                value: f32::INFINITY
            })
        );
        // Huge but finite: an error or a finite result.
        let mut huge = cal.clone();
        huge[0].0 = [f32::MAX, -f32::MAX, f32::MAX];
        if let Ok((rt, rms)) = RigidTransform::fit(&huge) {
            assert!(rms.is_finite() && rt.rotation().iter().flatten().all(|v| v.is_finite()));
        }
    }
}
