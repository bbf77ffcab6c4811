//! Regression tests of the bugs the fuzz targets (`fuzz/`, `scripts/fuzz.sh`) found, one test
//! per bug, through the public API as the targets call it. Each names the target and what it
//! found; `docs/reliability.md` lists them with the fix.

use vorl_core::pose::refine::outward_normal;
use vorl_core::shape::matching::{search_cells, table_cells};
use vorl_core::{Error, Params};

/// recognizer: `Params::validate` tested `2·k ≥ n` with `2·k` overflowing for
/// `k > usize::MAX / 2`: a panic in debug builds, and in release the product wrapped (to 0 for
/// `k = 2⁶³`), so a neighbourhood far larger than the contour passed as valid.
#[test]
fn validate_refuses_a_k_whose_double_overflows() {
    for k in [usize::MAX / 2 + 1, usize::MAX, usize::MAX / 2 + 2] {
        let p = Params { k, ..Params::DEFAULT };
        assert!(
            matches!(p.validate(), Err(Error::Parameter { name: "k", .. })),
            "k = {k}"
        );
    }
    // The valid range is unchanged: 1 ≤ k and 2k < n.
    let n = Params::DEFAULT.n;
    assert!(Params {
        k: n / 2 - 1,
        ..Params::DEFAULT
    }
    .validate()
    .is_ok());
    assert!(Params {
        k: n / 2,
        ..Params::DEFAULT
    }
    .validate()
    .is_err());
}

/// matching: `table_cells(n, m)` computed `n·(m − n + 1)` with overflow (a panic in debug
/// builds; in release a wrapped, small cell count, which a capacity check would have passed).
/// It saturates now, like `search_cells`.
#[test]
fn table_cells_saturates() {
    assert_eq!(table_cells(64, 96), 64 * 33);
    assert_eq!(table_cells(5, 4), 0);
    assert_eq!(table_cells(1 << 40, (1 << 41) - 1), usize::MAX);
    assert_eq!(table_cells(2, usize::MAX), usize::MAX);
    assert_eq!(table_cells(0, usize::MAX), 0);
    assert_eq!(search_cells(1 << 40, (1 << 41) - 1), usize::MAX);
}

/// geometry: `outward_normal(points, k, _)` read its neighbours at `(k + n − 1) mod n`, which
/// overflows for an empty outline (`k = 0`, `n = 0`) and for `k` near `usize::MAX` (a panic in
/// debug builds). Any `k` is taken modulo `n` first now, the same neighbours for every `k` that
/// did not overflow.
#[test]
fn outward_normal_takes_any_index() {
    let square = [[0.0f32, 0.0], [0.0, 2.0], [2.0, 2.0], [2.0, 0.0]];
    assert_eq!(outward_normal(&[], 0, true), None);
    assert_eq!(outward_normal(&[], usize::MAX, false), None);
    for k in 0..8 {
        assert_eq!(outward_normal(&square, k, true), outward_normal(&square, k % 4, true));
    }
    let far = usize::MAX - (usize::MAX % 4); // ≡ 0 mod 4
    assert_eq!(outward_normal(&square, far, true), outward_normal(&square, 0, true));
    assert_eq!(
        outward_normal(&square, usize::MAX, false),
        outward_normal(&square, 3, false)
    );
}

/// matching: `search_cells(0, usize::MAX)` computed `m − n + 1` with overflow (a panic in
/// debug builds). It saturates now.
#[test]
fn search_cells_saturates() {
    assert_eq!(search_cells(0, usize::MAX), usize::MAX);
    assert_eq!(search_cells(usize::MAX, usize::MAX), usize::MAX);
    assert_eq!(search_cells(5, 4), 0);
    // The usual sizes are unchanged: 2m + 4n + 7 + ⌈log2 m⌉·n + (n + w − 1)·⌈w/16⌉ + 3.
    assert_eq!(search_cells(64, 96), 2 * 96 + 4 * 64 + 7 + 7 * 64 + 96 * 3 + 3);
}

/// geometry: `angle_paper` returned `Some(NaN)` for a correspondence with non-finite offsets
/// (a NaN or infinite centroid or point: the cosine `v·w / (|v|·|w|)` is NaN). Such pairs are
/// not usable, like pairs at the centroid: the angle is finite or `None`.
#[test]
fn angle_paper_is_finite_or_none() {
    use vorl_core::pose::angle_paper;
    let pts = [[1.0f32, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
    let pairs = [0u16, 1, 2, 3];
    assert_eq!(angle_paper(&pts, [0.0, 0.0], &pts, [0.0, 0.0], &pairs), Some(0.0));
    assert_eq!(angle_paper(&pts, [f32::NAN, 0.0], &pts, [0.0, 0.0], &pairs), None);
    assert_eq!(angle_paper(&pts, [f32::INFINITY, 0.0], &pts, [0.0, 0.0], &pairs), None);
    let mixed = [[1.0f32, 0.0], [f32::NAN, 1.0], [-1.0, 0.0], [0.0, f32::INFINITY]];
    let a = angle_paper(&mixed, [0.0, 0.0], &pts, [0.0, 0.0], &pairs).unwrap();
    assert_eq!(a, 0.0, "the two finite pairs");
}

/// stereo: `StereoRig::depth` returned `Ok(0.0)` when `f·B/d` underflows (a tiny focal length
/// or baseline, which the rig accepts as positive), and `disparity` likewise `Ok(0.0)` for a
/// huge depth: a point at the camera, or at infinity. Both are errors now, as an overflow was.
#[test]
fn stereo_depth_and_disparity_never_zero() {
    use vorl_core::location::stereo::StereoRig;
    let rig = StereoRig::new(1e-45, 1e-3, 0.0, 0.0).unwrap();
    assert!(matches!(rig.depth(3.0), Err(Error::Disparity { .. })));
    assert!(rig.point(1.0, 1.0, 3.0).is_err());
    let tiny = StereoRig::new(1e-30, 1e-3, 0.0, 0.0).unwrap();
    assert!(matches!(
        tiny.disparity(1e20),
        Err(Error::Parameter { name: "depth_mm", .. })
    ));
    let rig = StereoRig::new(800.0, 60.0, 320.0, 240.0).unwrap();
    assert_eq!(rig.depth(48.0), Ok(1000.0));
    assert_eq!(rig.disparity(1000.0), Ok(48.0));
}

/// geometry: `resample::check_counts(n, m)` tested `m ≥ 2n` with `2n` overflowing for
/// `n > usize::MAX / 2` (a panic in debug builds; release gave the right answer by luck of the
/// wrap). It tests `m − n ≥ n` now.
#[test]
fn check_counts_takes_any_counts() {
    use vorl_core::borders::resample::check_counts;
    assert!(check_counts(64, 96).is_ok());
    assert!(check_counts(64, 127).is_ok());
    assert!(check_counts(64, 128).is_err());
    assert!(check_counts(64, 63).is_err());
    assert!(check_counts(0, 0).is_err());
    let huge = usize::MAX / 2 + 1;
    assert!(check_counts(huge, huge).is_ok());
    assert!(check_counts(huge, usize::MAX).is_ok());
    assert!(check_counts(usize::MAX, usize::MAX).is_ok());
    assert!(check_counts(huge, 3).is_err());
}

/// geometry: `refine::align` from a finite seed with a `cap` that is not a number returned
/// `distance: NaN` when no profile found an edge (each counted the cap). A cap that is not a
/// number or negative now caps nothing: such profiles count infinite, and the alignment is
/// never taken for a fit.
#[test]
fn align_with_a_nan_cap_gives_no_nan_distance() {
    use vorl_core::pixels::enhance::Alpha;
    use vorl_core::pose::refine::{align, edge_distances, Difference, Pose, RefineParams};
    use vorl_core::Frame;
    // A flat frame: no profile finds an edge.
    let px = vec![100u8; 48 * 40];
    let bg = vec![100u8; 48 * 40];
    let frame = Frame::new_checked(&px[..], 48, 40).unwrap();
    let diff = Difference::new(&frame, &bg, Alpha::ONE);
    let edge: Vec<[f32; 2]> = (0..16)
        .map(|i| {
            let t = i as f32 * core::f32::consts::TAU / 16.0;
            [5.0 * t.cos(), 5.0 * t.sin()]
        })
        .collect();
    let normals: Vec<[f32; 2]> = edge.iter().map(|e| [e[0] / 5.0, e[1] / 5.0]).collect();
    let seed = Pose {
        x: 24.0,
        y: 20.0,
        angle: 0.0,
        scale: 1.0,
    };
    for cap in [f32::NAN, -1.0, f32::NEG_INFINITY] {
        let rp = RefineParams {
            cap,
            ..RefineParams::DEFAULT
        };
        let a = align(&diff, &edge, &normals, seed, &rp);
        assert!(!a.distance.is_nan(), "cap {cap}: {a:?}");
        assert!(a.distance >= 0.0, "cap {cap}: {a:?}");
        let mut d = vec![0.0f32; edge.len()];
        let (sum, found) = edge_distances(&diff, &edge, &normals, seed, 0.0, &rp, &mut d);
        assert_eq!(found, 0);
        assert!(
            sum == f32::INFINITY && d.iter().all(|v| *v == f32::INFINITY),
            "cap {cap}: {sum}"
        );
    }
}
