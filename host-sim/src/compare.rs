//! Core against reference: both implementations on one input, every disagreement beyond the
//! stated tolerances reported.
//!
//! Stages compared (`docs/pipeline-spec.md`): the background model and the foreground mask
//! (pixel for pixel), the kept borders (point for point), and per part and template the
//! resampled points, descriptors, DP cost, decision, the two angle estimators over the DP
//! correspondences, and the area centroid.

use image::GrayImage;
use serde::Serialize;
use vorl_core::borders::contour::{trace_borders, BorderKind, ContourStore};
use vorl_core::borders::resample::resample;
use vorl_core::pixels::background::Background;
use vorl_core::pixels::mask::{foreground_mask, Cleanup, Polarity, Threshold};
use vorl_core::pose::{angle_paper, angle_signed, area_centroid};
use vorl_core::shape::descriptor::describe;
use vorl_core::shape::matching::{match_with_assignment, search_cells, table_cells};
use vorl_core::{Frame, Params, Template};

use crate::engine::{HOST_CONTOURS, HOST_M, HOST_POINTS};
use crate::reference as r;

/// The tolerances of a comparison.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Tolerances {
    /// Background / mask pixels allowed to differ (f32 against f64 rounding of I' when α < 1).
    pub pixels: usize,
    /// Resampled point coordinates, px.
    pub point_px: f64,
    /// Descriptor values, absolute.
    pub descriptor: f64,
    /// DP cost, relative.
    pub cost_rel: f64,
    /// Angles, degrees.
    pub angle_deg: f64,
    /// Centroids, px.
    pub centroid_px: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            pixels: 0,
            point_px: 1e-3,
            descriptor: 1e-3,
            cost_rel: 1e-3,
            angle_deg: 0.1,
            centroid_px: 1e-3,
        }
    }
}

/// One disagreement.
#[derive(Debug, Clone, Serialize)]
pub struct Disagreement {
    /// Where (frame, border, template).
    pub at: String,
    /// Which stage.
    pub stage: &'static str,
    /// What differs, with both values.
    pub detail: String,
}

/// What was compared and how far apart the two were at most.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Comparison {
    /// Frames compared.
    pub frames: usize,
    /// Borders compared point for point.
    pub borders: usize,
    /// Part × template DP runs compared.
    pub matches: usize,
    /// Matches where the two sides chose different optimal assignments (symmetric shapes); their
    /// angles are then compared on the core's assignment.
    pub ties: usize,
    /// Largest relative DP cost difference.
    pub max_cost_rel: f64,
    /// Largest angle difference (signed estimator), degrees.
    pub max_angle_deg: f64,
    /// Largest angle difference (paper estimator), degrees.
    pub max_angle_paper_deg: f64,
    /// Largest centroid difference, px.
    pub max_centroid_px: f64,
    /// Largest descriptor difference.
    pub max_descriptor: f64,
    /// Every disagreement beyond tolerance.
    pub disagreements: Vec<Disagreement>,
}

/// The reference's parameters for the core's.
pub fn ref_params(p: &Params) -> r::RefParams {
    r::RefParams {
        alpha: p.alpha as f64,
        threshold: match p.threshold {
            Threshold::Fixed(t) => r::RefThreshold::Fixed(t),
            Threshold::Otsu => r::RefThreshold::Otsu,
        },
        polarity: match p.polarity {
            Polarity::Either => r::RefPolarity::Either,
            Polarity::Darker => r::RefPolarity::Darker,
            Polarity::Brighter => r::RefPolarity::Brighter,
        },
        cleanup: match p.cleanup {
            Cleanup::Off => r::RefCleanup::Off,
            Cleanup::Open => r::RefCleanup::Open,
            Cleanup::OpenClose => r::RefCleanup::OpenClose,
        },
        min_points: p.min_points,
        min_area: p.min_area as f64,
        n: p.n,
        m: p.m,
        k: p.k,
        omega: p.omega as f64,
        epsilon: p.epsilon as f64,
    }
}

fn adiff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// Compares the two implementations on one frame against learned background frames and
/// template silhouettes, adding to `out`.
///
/// # Errors
/// Inputs that one side rejects while the other accepts are disagreements; inputs both reject
/// (a size mismatch) are errors.
pub fn compare_frame(
    name: &str,
    frame: &GrayImage,
    backgrounds: &[GrayImage],
    templates: &[GrayImage],
    params: &Params,
    tol: &Tolerances,
    out: &mut Comparison,
) -> Result<(), String> {
    let rp = ref_params(params);
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let mut bad = |stage: &'static str, at: String, detail: String| {
        out.disagreements.push(Disagreement { at, stage, detail });
    };
    // Background.
    let ref_bg = r::learn_background(backgrounds, rp.alpha).map_err(|e| format!("reference background: {e}"))?;
    let mut bg = Background::new(vec![0u8; w * h], w, h).map_err(|e| e.to_string())?;
    let mut high = vec![0u8; w * h];
    for b in backgrounds {
        let f = Frame::new_checked(b.as_raw().as_slice(), b.width() as usize, b.height() as usize)
            .map_err(|e| e.to_string())?;
        bg.learn(&f, params.alpha(), &mut high).map_err(|e| e.to_string())?;
    }
    bg.finish_learning(&high).map_err(|e| e.to_string())?;
    let differing = bg.plane().iter().zip(ref_bg.as_raw()).filter(|(a, b)| a != b).count();
    if differing > tol.pixels {
        bad("background", name.into(), format!("{differing} pixels differ"));
    }
    // Mask.
    let frame_view = Frame::new_checked(frame.as_raw().as_slice(), w, h).map_err(|e| e.to_string())?;
    let mut labels = vec![0u8; w * h];
    foreground_mask(
        &frame_view,
        &bg,
        params.alpha(),
        params.threshold,
        params.polarity,
        params.cleanup,
        &mut labels,
    )
    .map_err(|e| e.to_string())?;
    let ref_enh = r::enhance(frame, rp.alpha);
    let ref_mask =
        r::foreground_mask(&ref_enh, &ref_bg, rp.threshold, rp.polarity, rp.cleanup).map_err(|e| e.to_string())?;
    let differing = labels
        .iter()
        .zip(ref_mask.as_raw())
        .filter(|(a, b)| (**a != 0) != (**b != 0))
        .count();
    if differing > tol.pixels {
        bad("mask", name.into(), format!("{differing} pixels differ"));
    }
    // Borders: the core's kept borders against the reference's borders with the same filter.
    let mut store = Box::new(ContourStore::<HOST_POINTS, HOST_CONTOURS>::new());
    trace_borders(&mut labels, w, h, params.filter(), &mut store).map_err(|e| e.to_string())?;
    let ref_all = r::borders(&ref_mask);
    let ref_kept: Vec<&r::RefBorder> = ref_all
        .iter()
        .filter(|b| b.points.len() >= rp.min_points && r::polygon_area(&b.points) >= rp.min_area)
        .collect();
    if ref_kept.len() != store.contours().len() {
        bad(
            "borders",
            name.into(),
            format!(
                "core keeps {} borders, reference {}",
                store.contours().len(),
                ref_kept.len()
            ),
        );
    }
    // Templates on both sides.
    let mut core_tpls = Vec::new();
    let mut ref_tpls = Vec::new();
    for (ti, t) in templates.iter().enumerate() {
        let (tw, th) = (t.width() as usize, t.height() as usize);
        let mut tl = vec![0u8; tw * th];
        let mut ts = Box::new(ContourStore::<HOST_POINTS, HOST_CONTOURS>::new());
        let f = Frame::new_checked(t.as_raw().as_slice(), tw, th).map_err(|e| e.to_string())?;
        let ct = Template::<HOST_M>::from_silhouette(&f, params, &mut tl, &mut ts)
            .map_err(|e| format!("template {ti}: {e}"))?;
        let rt = r::template_from_silhouette(t, &rp).map_err(|e| format!("template {ti} (reference): {e}"))?;
        for (j, (a, b)) in ct.points().iter().zip(&rt.points).enumerate() {
            let d = ((a[0] as f64 - b.0).powi(2) + (a[1] as f64 - b.1).powi(2)).sqrt();
            if d > tol.point_px {
                bad(
                    "template points",
                    format!("template {ti} point {j}"),
                    format!("core {a:?} reference {b:?}"),
                );
                break;
            }
        }
        core_tpls.push(ct);
        ref_tpls.push(rt);
    }
    let n = params.n;
    let mut table = vec![0.0f32; search_cells(n, params.m).max(table_cells(n, params.m))];
    let mut assignment = vec![0u16; n];
    for (bi, (ci, rb)) in (0..store.contours().len()).zip(ref_kept.iter()).enumerate() {
        let at = format!("{name} border {bi}");
        let core_pts: Vec<(i32, i32)> = store.points(ci).iter().map(|p| (p.x as i32, p.y as i32)).collect();
        let c = store.contours()[ci];
        if core_pts != rb.points || (c.kind == BorderKind::Hole) != rb.is_hole {
            bad(
                "borders",
                at.clone(),
                format!(
                    "core {} points ({:?}), reference {} points",
                    core_pts.len(),
                    c.kind,
                    rb.points.len()
                ),
            );
            continue;
        }
        out.borders += 1;
        if c.kind != BorderKind::Outer {
            continue;
        }
        // Centroid (holes: the kept holes whose parent is this border).
        let core_c = area_centroid(store.points(ci), store.holes_of(ci).map(|i| store.points(i)));
        let ref_holes: Vec<&[(i32, i32)]> = store
            .holes_of(ci)
            .filter_map(|hi| ref_kept.get(hi).map(|b| b.points.as_slice()))
            .collect();
        let ref_c = r::area_centroid(&rb.points, &ref_holes);
        if let (Some(a), Some(b)) = (core_c, ref_c) {
            let d = ((a[0] as f64 - b.0).powi(2) + (a[1] as f64 - b.1).powi(2)).sqrt();
            out.max_centroid_px = out.max_centroid_px.max(d);
            if d > tol.centroid_px {
                bad("centroid", at.clone(), format!("core {a:?} reference {b:?}"));
            }
        } else if core_c.is_some() != ref_c.is_some() {
            bad("centroid", at.clone(), format!("core {core_c:?} reference {ref_c:?}"));
        }
        // Resample and describe.
        let mut pts = vec![[0.0f32; 2]; n];
        let mut desc = vec![0.0f32; n];
        let core_ok =
            resample(store.points(ci), &mut pts).and_then(|_| describe(&pts, params.descriptor(n), &mut desc));
        let rpts_in: Vec<(f64, f64)> = rb.points.iter().map(|&(x, y)| (x as f64, y as f64)).collect();
        let ref_ok = r::resample(&rpts_in, n).and_then(|q| r::descriptor(&q, rp.k, rp.omega).map(|d| (q, d)));
        let (pc, (rq, rd)) = match (core_ok, ref_ok) {
            (Ok(c), Ok(r)) => (c, r),
            (Err(_), Err(_)) => continue,
            (a, b) => {
                bad(
                    "descriptor",
                    at.clone(),
                    format!("core {:?}, reference {:?}", a.err(), b.err()),
                );
                continue;
            }
        };
        let dmax = desc
            .iter()
            .zip(&rd)
            .map(|(a, b)| (*a as f64 - b).abs())
            .fold(0.0, f64::max);
        out.max_descriptor = out.max_descriptor.max(dmax);
        if dmax > tol.descriptor {
            bad("descriptor", at.clone(), format!("values differ by up to {dmax:.2e}"));
        }
        let pmax = pts
            .iter()
            .zip(&rq)
            .map(|(a, b)| ((a[0] as f64 - b.0).powi(2) + (a[1] as f64 - b.1).powi(2)).sqrt())
            .fold(0.0, f64::max);
        if pmax > tol.point_px {
            bad("resample", at.clone(), format!("points differ by up to {pmax:.2e} px"));
        }
        for (ti, (ct, rt)) in core_tpls.iter().zip(&ref_tpls).enumerate() {
            let at = format!("{at} template {ti}");
            let cm = match match_with_assignment(&desc, ct.descriptor(), &mut table, &mut assignment) {
                Ok(m) => m,
                Err(e) => {
                    bad("dp", at, format!("core failed: {e}"));
                    continue;
                }
            };
            let rm = match r::cyclic_dp(&rd, &rt.descriptor) {
                Ok(m) => m,
                Err(e) => {
                    bad("dp", at, format!("reference failed: {e}"));
                    continue;
                }
            };
            out.matches += 1;
            let rel = (cm.cost as f64 - rm.cost).abs() / rm.cost.abs().max(1e-6);
            out.max_cost_rel = out.max_cost_rel.max(rel);
            if rel > tol.cost_rel {
                bad(
                    "dp",
                    at.clone(),
                    format!("cost core {} reference {} (relative {rel:.2e})", cm.cost, rm.cost),
                );
            }
            if (cm.normalized < params.epsilon) != (rm.normalized < rp.epsilon) && rel > tol.cost_rel {
                bad(
                    "decision",
                    at.clone(),
                    format!("f' core {} reference {}", cm.normalized, rm.normalized),
                );
            }
            let tc = ct.centroid();
            let cs = angle_signed(&pts, pc, ct.points(), tc, &assignment).unwrap_or(0.0) as f64;
            let cp = angle_paper(&pts, pc, ct.points(), tc, &assignment).unwrap_or(0.0) as f64;
            let rs = r::angle_signed(&rq, &rt.points, &rm.assignment);
            let rpap = r::angle_paper(&rq, &rt.points, &rm.assignment);
            let (mut da, mut dp) = (adiff(cs, rs), adiff(cp, rpap));
            if da > tol.angle_deg || dp > tol.angle_deg {
                // Several optimal assignments (a symmetric shape): hold the core's assignment to be
                // optimal for the reference too, and compare the angle formulas on it.
                let asg: Vec<usize> = assignment.iter().map(|&j| j as usize).collect();
                let ref_cost_of_core: f64 = rd
                    .iter()
                    .zip(&asg)
                    .map(|(a, &j)| (a - rt.descriptor[j % rt.descriptor.len()]).abs())
                    .sum();
                let tie = (ref_cost_of_core - rm.cost).abs() <= tol.cost_rel * rm.cost.abs().max(1e-6);
                if tie {
                    out.ties += 1;
                    da = adiff(cs, r::angle_signed(&rq, &rt.points, &asg));
                    dp = adiff(cp, r::angle_paper(&rq, &rt.points, &asg));
                }
            }
            out.max_angle_deg = out.max_angle_deg.max(da);
            out.max_angle_paper_deg = out.max_angle_paper_deg.max(dp);
            if da > tol.angle_deg {
                bad(
                    "angle (signed)",
                    at.clone(),
                    format!("core {cs:.4}° reference {rs:.4}° (reference's optimum not tied with the core's)"),
                );
            }
            if dp > tol.angle_deg {
                bad(
                    "angle (paper)",
                    at.clone(),
                    format!("core {cp:.4}° reference {rpap:.4}°"),
                );
            }
        }
    }
    out.frames += 1;
    Ok(())
}
