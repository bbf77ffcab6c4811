//! A rectified pinhole stereo rig: depth from disparity, the 3-D point, and which part found in
//! the left image is which part in the right one.
//!
//! The paper's section 6: "as long as the disparity of the same point on one object has been
//! obtained through two images captured by the binocular visual system, the location coordinate
//! of that point in the camera physical coordinates can be fixed. The center of contour can be
//! regarded as one representative point". `DESIGN.md` ("Stereo", and `camera.json` under
//! "Contracts") fixes the conventions used here:
//!
//! - the pair is **rectified**: both cameras share the focal length `f_px` (pixels) and the
//!   principal point `(cx, cy)`, their image rows are aligned, and the right camera sits at
//!   `+baseline_mm` along the left camera's x axis;
//! - **disparity** `d = x_left − x_right` (pixels), positive for any point in front of the rig;
//! - **depth** `Z = f·B / d` (millimetres, along the optical axis);
//! - the **camera frame** is the left camera's: origin at its centre, x right, y down (as the
//!   image), z forward, millimetres: `X = (x − cx)·Z/f`, `Y = (y − cy)·Z/f`.
//!
//! A [`crate::calibrate::RigidTransform`] takes the camera-frame point on to the robot's frame.
//!
//! Pairing ([`pair_parts`]): the parts found in the left and right images are paired by class,
//! row and disparity; the paper's centroid disparity is what comes out. (A sub-pixel refinement
//! of the disparity by aligning the part's borders along the row, `DESIGN.md` "Stereo", is a
//! later stage and not part of this module.)
//!
//! ## Time and memory
//!
//! [`StereoRig`] methods: constant time, a few `f32` operations, no storage. [`pair_parts`]:
//! `O(min(L, R)·L·R)` comparisons for `L` left and `R` right parts (one `O(L·R)` scan per pair
//! made), 152 bytes of stack on `thumbv7em-none-eabihf` (the `[bool; MAX_RIGHT_PARTS]` taken
//! flags and locals), and the caller's output slice of `L` outcomes (12 bytes each on a 32-bit target).

use crate::error::{Error, Result};
use crate::recognizer::Detection;

/// A rectified pinhole stereo pair (see the module documentation for the conventions).
///
/// ```
/// use vorl_core::stereo::StereoRig;
/// // f = 800 px, baseline 60 mm, principal point (320, 240).
/// let rig = StereoRig::new(800.0, 60.0, 320.0, 240.0)?;
/// // A part at x = 400 in the left image and x = 352 in the right: d = 48 px.
/// assert_eq!(rig.depth(48.0)?, 1000.0);
/// let [x, y, z] = rig.point(400.0, 200.0, 48.0)?;
/// assert_eq!([x, y, z], [100.0, -50.0, 1000.0]);
/// assert_eq!(rig.disparity(1000.0)?, 48.0);
/// assert!(rig.depth(0.0).is_err());
/// # Ok::<(), vorl_core::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StereoRig {
    f_px: f32,
    baseline_mm: f32,
    cx: f32,
    cy: f32,
}

impl StereoRig {
    /// A rig with focal length `f_px` (pixels, both cameras), baseline `baseline_mm` (the right
    /// camera's offset along +x, millimetres) and principal point `(cx, cy)` (pixels).
    ///
    /// # Errors
    ///
    /// [`Error::Parameter`] named `"f_px"` or `"baseline_mm"` when zero, negative or not finite,
    /// `"cx"` or `"cy"` when not finite.
    pub fn new(f_px: f32, baseline_mm: f32, cx: f32, cy: f32) -> Result<StereoRig> {
        for (name, value) in [("f_px", f_px), ("baseline_mm", baseline_mm)] {
            if !value.is_finite() || value <= 0.0 {
                return Err(Error::Parameter { name, value });
            }
        }
        for (name, value) in [("cx", cx), ("cy", cy)] {
            if !value.is_finite() {
                return Err(Error::Parameter { name, value });
            }
        }
        Ok(StereoRig {
            f_px,
            baseline_mm,
            cx,
            cy,
        })
    }

    /// Focal length, pixels.
    pub fn f_px(&self) -> f32 {
        self.f_px
    }

    /// Baseline, millimetres.
    pub fn baseline_mm(&self) -> f32 {
        self.baseline_mm
    }

    /// Principal point `(cx, cy)`, pixels.
    pub fn principal_point(&self) -> [f32; 2] {
        [self.cx, self.cy]
    }

    /// Depth `Z = f·B / d` in millimetres of a point with disparity `d = x_left − x_right`
    /// (pixels).
    ///
    /// # Errors
    ///
    /// [`Error::Disparity`] when `d` is zero, negative or not finite, or so small that `Z`
    /// overflows `f32`.
    pub fn depth(&self, disparity: f32) -> Result<f32> {
        if !disparity.is_finite() || disparity <= 0.0 {
            return Err(Error::Disparity { disparity });
        }
        let z = self.f_px * self.baseline_mm / disparity;
        if !z.is_finite() {
            return Err(Error::Disparity { disparity });
        }
        Ok(z)
    }

    /// The disparity (pixels) of a point at depth `depth_mm`, `d = f·B / Z`: the inverse of
    /// [`StereoRig::depth`], e.g. to set [`PairParams::max_disparity_px`] from the nearest depth
    /// the rig must see.
    ///
    /// # Errors
    ///
    /// [`Error::Parameter`] (`"depth_mm"`) when the depth is zero, negative, not finite, or so
    /// small that the disparity overflows `f32`.
    pub fn disparity(&self, depth_mm: f32) -> Result<f32> {
        if !depth_mm.is_finite() || depth_mm <= 0.0 {
            return Err(Error::Parameter {
                name: "depth_mm",
                value: depth_mm,
            });
        }
        let d = self.f_px * self.baseline_mm / depth_mm;
        if !d.is_finite() {
            return Err(Error::Parameter {
                name: "depth_mm",
                value: depth_mm,
            });
        }
        Ok(d)
    }

    /// The 3-D point `[X, Y, Z]` in the left camera's frame (millimetres; x right, y down, z
    /// forward) of the left-image pixel `(x_left, y_left)` with disparity `d`:
    /// `Z = f·B/d`, `X = (x − cx)·Z/f`, `Y = (y − cy)·Z/f`.
    ///
    /// # Errors
    ///
    /// [`Error::Parameter`] (`"x_left"`, `"y_left"`) for a non-finite coordinate;
    /// [`Error::Disparity`] as for [`StereoRig::depth`], and when `X` or `Y` overflows.
    pub fn point(&self, x_left: f32, y_left: f32, disparity: f32) -> Result<[f32; 3]> {
        for (name, value) in [("x_left", x_left), ("y_left", y_left)] {
            if !value.is_finite() {
                return Err(Error::Parameter { name, value });
            }
        }
        let z = self.depth(disparity)?;
        // (x − cx)·B/d equals (x − cx)·Z/f and rounds once less.
        let x = (x_left - self.cx) * self.baseline_mm / disparity;
        let y = (y_left - self.cy) * self.baseline_mm / disparity;
        if !x.is_finite() || !y.is_finite() {
            return Err(Error::Disparity { disparity });
        }
        Ok([x, y, z])
    }
}

/// One part found in one image of the pair, as [`pair_parts`] needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StereoPart {
    /// Template index, `None` for an unknown part (as [`Detection::template`]).
    pub class: Option<u16>,
    /// Position x (pixels; the area centroid).
    pub x: f32,
    /// Position y (pixels).
    pub y: f32,
    /// Angle, degrees counter-clockwise on screen. Carried for the caller; pairing does not
    /// use it (a symmetric part's angle is ambiguous, and class, row and disparity decide).
    pub angle_deg: f32,
}

impl From<&Detection> for StereoPart {
    fn from(d: &Detection) -> StereoPart {
        StereoPart {
            class: d.template,
            x: d.x,
            y: d.y,
            angle_deg: d.angle_deg,
        }
    }
}

/// Most right-image parts [`pair_parts`] takes at once (the size of its on-stack "taken" flags).
pub const MAX_RIGHT_PARTS: usize = 64;

/// Rules of [`pair_parts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairParams {
    /// Largest difference of the rows (`|y_left − y_right|`, pixels) of a pair. Rectified rows
    /// agree up to the centroid's noise and the rectification's error: about a pixel.
    pub row_tolerance_px: f32,
    /// Largest disparity (pixels) of a pair: the disparity of the nearest depth the rig must
    /// see ([`StereoRig::disparity`]).
    pub max_disparity_px: f32,
}

impl PairParams {
    /// Row tolerance 2 px, disparity up to 256 px.
    pub const DEFAULT: PairParams = PairParams {
        row_tolerance_px: 2.0,
        max_disparity_px: 256.0,
    };

    /// Checks the rules.
    ///
    /// # Errors
    ///
    /// [`Error::Parameter`]: `"row_tolerance_px"` negative or not finite,
    /// `"max_disparity_px"` not positive or not finite.
    pub fn validate(&self) -> Result<()> {
        let r = self.row_tolerance_px;
        if !r.is_finite() || r < 0.0 {
            return Err(Error::Parameter {
                name: "row_tolerance_px",
                value: r,
            });
        }
        let d = self.max_disparity_px;
        if !d.is_finite() || d <= 0.0 {
            return Err(Error::Parameter {
                name: "max_disparity_px",
                value: d,
            });
        }
        Ok(())
    }
}

impl Default for PairParams {
    fn default() -> Self {
        PairParams::DEFAULT
    }
}

/// Why a left part has no partner in the right image. The checks run in this order, and the
/// reason given is the furthest any right part got.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unpaired {
    /// The left part's position is not finite.
    NonFinite,
    /// The right image holds no part (with a finite position).
    NoRightParts,
    /// No right part has the same class (an unknown part pairs only with an unknown one).
    ClassMismatch,
    /// Right parts of the same class exist, but none within the row tolerance.
    RowMismatch,
    /// Parts of the same class and row exist, but only at zero or negative disparity
    /// (`x_right ≥ x_left`).
    NonPositiveDisparity,
    /// Parts of the same class and row exist, but only beyond the largest disparity.
    DisparityTooLarge,
    /// Every right part that fits was paired with another left part that fits it better.
    Taken,
}

/// What became of one left part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PairOutcome {
    /// Paired with the right part of this index, at this disparity `x_left − x_right` (px).
    Paired {
        /// Index into the right parts.
        right: usize,
        /// `x_left − x_right`, pixels, in `(0, max_disparity_px]`.
        disparity: f32,
    },
    /// Not paired, and why.
    Unpaired(Unpaired),
}

impl PairOutcome {
    /// The right index and disparity of a pair, `None` when unpaired.
    pub fn paired(&self) -> Option<(usize, f32)> {
        match *self {
            PairOutcome::Paired { right, disparity } => Some((right, disparity)),
            PairOutcome::Unpaired(_) => None,
        }
    }
}

/// How far a right part gets through the checks for a left part; `Ok(d)` is a candidate at
/// disparity `d`.
fn check(l: &StereoPart, r: &StereoPart, params: &PairParams) -> core::result::Result<f32, Unpaired> {
    if l.class != r.class {
        return Err(Unpaired::ClassMismatch);
    }
    let dy = (l.y - r.y).abs();
    if dy.is_nan() || dy > params.row_tolerance_px {
        return Err(Unpaired::RowMismatch);
    }
    let d = l.x - r.x;
    if d.is_nan() || d <= 0.0 {
        return Err(Unpaired::NonPositiveDisparity);
    }
    if d > params.max_disparity_px {
        return Err(Unpaired::DisparityTooLarge);
    }
    Ok(d)
}

/// Rank of a failed check (higher got further).
fn rank(u: Unpaired) -> u8 {
    match u {
        Unpaired::NonFinite | Unpaired::NoRightParts => 0,
        Unpaired::ClassMismatch => 1,
        Unpaired::RowMismatch => 2,
        Unpaired::NonPositiveDisparity => 3,
        Unpaired::DisparityTooLarge => 4,
        Unpaired::Taken => 5,
    }
}

fn finite(p: &StereoPart) -> bool {
    p.x.is_finite() && p.y.is_finite()
}

/// Pairs the parts found in the left image with those found in the right one and writes one
/// [`PairOutcome`] per left part into `out[..left.len()]`; returns the number of pairs made.
///
/// A left part `l` and a right part `r` can pair when they have the same class (`None` pairs
/// with `None`: an unknown part with an unknown one), their rows agree,
/// `|y_l − y_r| ≤ row_tolerance_px`, and the disparity `d = x_l − x_r` is positive and at most
/// `max_disparity_px`. Each part is used at most once. Among all possible pairs the one with the
/// smallest row difference is made first, ties broken by the smaller disparity (the farther
/// part), then by the lower left and right index; then the next among the parts still free,
/// and so on (greedy, not a global optimum: with rectified rows the row difference of a true
/// pair is near zero, so the greedy order is the right one unless two same-class parts share a
/// row). Every left part left over is reported with its reason ([`Unpaired`]); right parts with
/// a non-finite position are never paired.
///
/// ```
/// use vorl_core::stereo::{pair_parts, PairOutcome, PairParams, StereoPart, Unpaired};
/// let part = |class, x, y| StereoPart { class, x, y, angle_deg: 0.0 };
/// let left = [part(Some(0), 300.0, 100.0), part(Some(1), 200.0, 240.0), part(Some(2), 50.0, 50.0)];
/// let right = [part(Some(1), 180.0, 240.5), part(Some(0), 260.0, 100.2)];
/// let mut out = [PairOutcome::Unpaired(Unpaired::NoRightParts); 3];
/// let pairs = pair_parts(&left, &right, &PairParams::DEFAULT, &mut out)?;
/// assert_eq!(pairs, 2);
/// assert_eq!(out[0], PairOutcome::Paired { right: 1, disparity: 40.0 });
/// assert_eq!(out[1], PairOutcome::Paired { right: 0, disparity: 20.0 });
/// assert_eq!(out[2], PairOutcome::Unpaired(Unpaired::ClassMismatch));
/// # Ok::<(), vorl_core::Error>(())
/// ```
///
/// # Errors
///
/// [`Error::Parameter`] from [`PairParams::validate`]; [`Error::BufferTooSmall`] when `out` is
/// shorter than `left`; [`Error::Capacity`] when `right` holds more than [`MAX_RIGHT_PARTS`].
/// Entries of `out` past `left.len()` are left as they were.
pub fn pair_parts(
    left: &[StereoPart],
    right: &[StereoPart],
    params: &PairParams,
    out: &mut [PairOutcome],
) -> Result<usize> {
    params.validate()?;
    if out.len() < left.len() {
        return Err(Error::BufferTooSmall {
            needed: left.len(),
            got: out.len(),
        });
    }
    if right.len() > MAX_RIGHT_PARTS {
        return Err(Error::Capacity {
            what: "right-image parts to pair",
            capacity: MAX_RIGHT_PARTS,
            requested: right.len(),
        });
    }
    // First, what each left part could get at best. Parts with a candidate start as
    // `Unpaired(Taken)` and are the ones the greedy rounds look at.
    for (l, o) in left.iter().zip(out.iter_mut()) {
        *o = PairOutcome::Unpaired(if !finite(l) {
            Unpaired::NonFinite
        } else {
            let mut best = Unpaired::NoRightParts;
            for r in right.iter().filter(|r| finite(r)) {
                let reason = check(l, r, params).err().unwrap_or(Unpaired::Taken);
                if rank(reason) > rank(best) {
                    best = reason;
                }
            }
            best
        });
    }
    let mut taken = [false; MAX_RIGHT_PARTS];
    let mut pairs = 0usize;
    loop {
        // The best remaining pair: smallest row difference, then smallest disparity.
        let mut best: Option<(f32, f32, usize, usize)> = None;
        for (i, (l, o)) in left.iter().zip(out.iter()).enumerate() {
            if *o != PairOutcome::Unpaired(Unpaired::Taken) {
                continue;
            }
            for (j, (r, &t)) in right.iter().zip(taken.iter()).enumerate() {
                if t || !finite(r) {
                    continue;
                }
                let Ok(d) = check(l, r, params) else { continue };
                let dy = (l.y - r.y).abs();
                let better = match best {
                    None => true,
                    Some((bdy, bd, _, _)) => dy < bdy || (dy == bdy && d < bd),
                };
                if better {
                    best = Some((dy, d, i, j));
                }
            }
        }
        let Some((_, d, i, j)) = best else { break };
        if let (Some(o), Some(t)) = (out.get_mut(i), taken.get_mut(j)) {
            *o = PairOutcome::Paired { right: j, disparity: d };
            *t = true;
            pairs += 1;
        } else {
            break;
        }
    }
    Ok(pairs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(class: Option<u16>, x: f32, y: f32) -> StereoPart {
        StereoPart {
            class,
            x,
            y,
            angle_deg: 0.0,
        }
    }

    const NONE: PairOutcome = PairOutcome::Unpaired(Unpaired::NoRightParts);

    #[test]
    fn rig_checks_parameters() {
        assert!(StereoRig::new(800.0, 60.0, 320.0, 240.0).is_ok());
        for (f, b, name, value) in [
            (0.0, 60.0, "f_px", 0.0),
            (-1.0, 60.0, "f_px", -1.0),
            (f32::INFINITY, 60.0, "f_px", f32::INFINITY),
            (800.0, 0.0, "baseline_mm", 0.0),
            (800.0, -5.0, "baseline_mm", -5.0),
        ] {
            assert_eq!(
                StereoRig::new(f, b, 320.0, 240.0),
                Err(Error::Parameter { name, value })
            );
        }
        assert!(matches!(
            StereoRig::new(f32::NAN, 60.0, 0.0, 0.0),
            Err(Error::Parameter { name: "f_px", .. })
        ));
        assert!(matches!(
            StereoRig::new(800.0, f32::NAN, 0.0, 0.0),
            Err(Error::Parameter {
                name: "baseline_mm",
                ..
            })
        ));
        assert!(matches!(
            StereoRig::new(800.0, 60.0, f32::NAN, 0.0),
            Err(Error::Parameter { name: "cx", .. })
        ));
        assert!(matches!(
            StereoRig::new(800.0, 60.0, 0.0, f32::NEG_INFINITY),
            Err(Error::Parameter { name: "cy", .. })
        ));
    }

    #[test]
    fn depth_and_point_round_trip() {
        let rig = StereoRig::new(812.5, 75.0, 319.5, 241.25).unwrap();
        for z in [300.0f32, 650.0, 1000.0, 2500.0] {
            let d = rig.disparity(z).unwrap();
            let back = rig.depth(d).unwrap();
            assert!((back - z).abs() <= 1e-5 * z, "{z} → {d} → {back}");
            // Project a camera point into both images and back.
            for (x, y) in [(0.0f32, 0.0f32), (-120.0, 80.0), (200.0, -150.0)] {
                let xl = rig.f_px() * x / z + 319.5;
                let yl = rig.f_px() * y / z + 241.25;
                let xr = rig.f_px() * (x - rig.baseline_mm()) / z + 319.5;
                let p = rig.point(xl, yl, xl - xr).unwrap();
                for (got, want) in p.iter().zip([x, y, z]) {
                    assert!((got - want).abs() <= 1e-4 * z, "{p:?} vs {:?}", [x, y, z]);
                }
            }
        }
        assert_eq!(rig.principal_point(), [319.5, 241.25]);
    }

    #[test]
    fn depth_guards() {
        let rig = StereoRig::new(800.0, 60.0, 320.0, 240.0).unwrap();
        for d in [0.0f32, -3.0, f32::INFINITY, f32::MIN_POSITIVE / 1e6] {
            assert_eq!(rig.depth(d), Err(Error::Disparity { disparity: d }));
            assert_eq!(rig.point(1.0, 1.0, d), Err(Error::Disparity { disparity: d }));
        }
        assert!(matches!(rig.depth(f32::NAN), Err(Error::Disparity { disparity }) if disparity.is_nan()));
        assert!(matches!(
            rig.point(f32::NAN, 1.0, 4.0),
            Err(Error::Parameter { name: "x_left", .. })
        ));
        assert!(matches!(
            rig.point(1.0, f32::INFINITY, 4.0),
            Err(Error::Parameter { name: "y_left", .. })
        ));
        assert!(matches!(
            rig.disparity(0.0),
            Err(Error::Parameter { name: "depth_mm", .. })
        ));
        assert!(matches!(
            rig.disparity(f32::NAN),
            Err(Error::Parameter { name: "depth_mm", .. })
        ));
        // Large x with a tiny (but finite-depth) disparity overflows X.
        assert_eq!(rig.point(3e38, 1.0, 1e-3), Err(Error::Disparity { disparity: 1e-3 }));
    }

    #[test]
    fn pairs_by_class_row_and_disparity() {
        let left = [
            part(Some(0), 300.0, 100.0), // → right 1
            part(Some(1), 200.0, 240.0), // only right of class 1 is 10 px off in row
            part(Some(2), 150.0, 60.0),  // class 2 only at negative disparity
            part(Some(3), 500.0, 300.0), // class 3 only beyond the max disparity
            part(Some(4), 100.0, 100.0), // no class 4 on the right
            part(None, 400.0, 400.0),    // unknown pairs with unknown
        ];
        let right = [
            part(Some(1), 180.0, 250.0),
            part(Some(0), 262.0, 100.5),
            part(Some(2), 170.0, 60.0),
            part(Some(3), 100.0, 300.0),
            part(None, 390.0, 401.0),
        ];
        let params = PairParams {
            row_tolerance_px: 2.0,
            max_disparity_px: 300.0,
        };
        let mut out = [NONE; 6];
        assert_eq!(pair_parts(&left, &right, &params, &mut out), Ok(2));
        assert_eq!(
            out[0],
            PairOutcome::Paired {
                right: 1,
                disparity: 38.0
            }
        );
        assert_eq!(out[1], PairOutcome::Unpaired(Unpaired::RowMismatch));
        assert_eq!(out[2], PairOutcome::Unpaired(Unpaired::NonPositiveDisparity));
        assert_eq!(out[3], PairOutcome::Unpaired(Unpaired::DisparityTooLarge));
        assert_eq!(out[4], PairOutcome::Unpaired(Unpaired::ClassMismatch));
        assert_eq!(out[5].paired(), Some((4, 10.0)));
        // Zero disparity is not positive.
        let mut one = [NONE];
        pair_parts(
            &[part(Some(0), 10.0, 0.0)],
            &[part(Some(0), 10.0, 0.0)],
            &params,
            &mut one,
        )
        .unwrap();
        assert_eq!(one[0], PairOutcome::Unpaired(Unpaired::NonPositiveDisparity));
        // Exactly at the tolerances pairs.
        pair_parts(
            &[part(Some(0), 310.0, 2.0)],
            &[part(Some(0), 10.0, 0.0)],
            &params,
            &mut one,
        )
        .unwrap();
        assert_eq!(
            one[0],
            PairOutcome::Paired {
                right: 0,
                disparity: 300.0
            }
        );
    }

    #[test]
    fn each_part_used_once_greedy_order() {
        // Two left parts of class 0 on nearly the same row, one right part: the smaller row
        // difference wins, the other is reported as taken.
        let left = [part(Some(0), 300.0, 101.0), part(Some(0), 320.0, 100.2)];
        let right = [part(Some(0), 280.0, 100.0)];
        let mut out = [NONE; 2];
        assert_eq!(pair_parts(&left, &right, &PairParams::DEFAULT, &mut out), Ok(1));
        assert_eq!(out[0], PairOutcome::Unpaired(Unpaired::Taken));
        assert_eq!(
            out[1],
            PairOutcome::Paired {
                right: 0,
                disparity: 40.0
            }
        );
        // Same row: the smaller disparity is made first, and the other left part takes the
        // remaining right part.
        let left = [part(Some(0), 300.0, 100.0), part(Some(0), 500.0, 100.0)];
        let right = [part(Some(0), 250.0, 100.0), part(Some(0), 480.0, 100.0)];
        let mut out = [NONE; 2];
        assert_eq!(pair_parts(&left, &right, &PairParams::DEFAULT, &mut out), Ok(2));
        assert_eq!(
            out[0],
            PairOutcome::Paired {
                right: 0,
                disparity: 50.0
            }
        );
        assert_eq!(
            out[1],
            PairOutcome::Paired {
                right: 1,
                disparity: 20.0
            }
        );
        // No right part is used twice, whatever the input.
        let left = [part(Some(0), 300.0, 100.0); 4];
        let right = [part(Some(0), 290.0, 100.0), part(Some(0), 280.0, 100.0)];
        let mut out = [NONE; 4];
        assert_eq!(pair_parts(&left, &right, &PairParams::DEFAULT, &mut out), Ok(2));
        let used: heapless::Vec<usize, 4> = out.iter().filter_map(|o| o.paired().map(|p| p.0)).collect();
        assert_eq!(used.as_slice(), &[0, 1]);
        assert_eq!(out[2], PairOutcome::Unpaired(Unpaired::Taken));
        assert_eq!(out[3], PairOutcome::Unpaired(Unpaired::Taken));
    }

    #[test]
    fn unpaired_are_reported_and_inputs_checked() {
        let mut out = [PairOutcome::Paired {
            right: 9,
            disparity: 1.0,
        }; 3];
        let left = [part(Some(0), 10.0, 10.0), part(Some(0), f32::NAN, 10.0)];
        assert_eq!(pair_parts(&left, &[], &PairParams::DEFAULT, &mut out), Ok(0));
        assert_eq!(out[0], PairOutcome::Unpaired(Unpaired::NoRightParts));
        assert_eq!(out[1], PairOutcome::Unpaired(Unpaired::NonFinite));
        // Untouched past left.len().
        assert_eq!(
            out[2],
            PairOutcome::Paired {
                right: 9,
                disparity: 1.0
            }
        );
        // A right part with a NaN position is never a candidate.
        let right = [part(Some(0), f32::NAN, 10.0)];
        assert_eq!(pair_parts(&left[..1], &right, &PairParams::DEFAULT, &mut out), Ok(0));
        assert_eq!(out[0], PairOutcome::Unpaired(Unpaired::NoRightParts));
        // Output too short, too many right parts, bad parameters.
        assert_eq!(
            pair_parts(&left, &[], &PairParams::DEFAULT, &mut out[..1]),
            Err(Error::BufferTooSmall { needed: 2, got: 1 })
        );
        let many = [part(Some(0), 0.0, 0.0); MAX_RIGHT_PARTS + 1];
        assert_eq!(
            pair_parts(&left, &many, &PairParams::DEFAULT, &mut out),
            Err(Error::Capacity {
                what: "right-image parts to pair",
                capacity: MAX_RIGHT_PARTS,
                requested: MAX_RIGHT_PARTS + 1
            })
        );
        let bad = PairParams {
            row_tolerance_px: -1.0,
            ..PairParams::DEFAULT
        };
        assert_eq!(
            pair_parts(&left, &[], &bad, &mut out),
            Err(Error::Parameter {
                name: "row_tolerance_px",
                value: -1.0
            })
        );
        let bad = PairParams {
            max_disparity_px: 0.0,
            ..PairParams::DEFAULT
        };
        assert_eq!(
            pair_parts(&left, &[], &bad, &mut out),
            Err(Error::Parameter {
                name: "max_disparity_px",
                value: 0.0
            })
        );
        // Empty left: nothing to do.
        assert_eq!(pair_parts(&[], &many[..3], &PairParams::DEFAULT, &mut []), Ok(0));
    }

    #[test]
    fn from_detection() {
        let d = Detection {
            template: Some(3),
            best_template: Some(3),
            score: 0.1,
            x: 12.0,
            y: 34.0,
            angle_deg: 56.0,
            angle_paper_deg: 56.0,
            angle_dp_deg: 56.0,
            polygon_centroid: [12.0, 34.0],
            verify: 0.1,
            scale: 1.0,
            contour: 0,
            area: 100.0,
            touches_edge: false,
        };
        assert_eq!(
            StereoPart::from(&d),
            StereoPart {
                class: Some(3),
                x: 12.0,
                y: 34.0,
                angle_deg: 56.0
            }
        );
    }
}
