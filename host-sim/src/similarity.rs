//! All-pairs `f'` between silhouettes: which parts the matcher will confuse.
//!
//! Each silhouette is described twice with the core's own stages: as a part (`n` points, what a
//! frame would give) and as a template (`m` points). Entry `(i, j)` of the matrix is `f'` of
//! silhouette `i` seen as a part against silhouette `j` as a template (eq. 5.1), so the matrix is
//! not quite symmetric. A pair whose `f'` is below `ε` in either direction cannot be told apart
//! at that `ε`.

use image::GrayImage;
use rayon::prelude::*;
use serde::Serialize;
use vorl_core::borders::contour::{trace_borders, BorderFilter, ContourStore};
use vorl_core::borders::resample::resample;
use vorl_core::shape::descriptor::describe;
use vorl_core::shape::matching::best_cost;
use vorl_core::{Params, Template};

use crate::engine::{NamedSilhouette, HOST_CONTOURS, HOST_M, HOST_POINTS};

/// One silhouette described as a part and as a template.
pub struct Described {
    /// Name.
    pub name: String,
    /// Part descriptor (`n` values).
    pub part: Vec<f32>,
    /// Template (`m` points).
    pub template: Box<Template<HOST_M>>,
}

/// Describes a silhouette (part > 127) with the core's stages.
///
/// # Errors
/// No part in the image, or a border that cannot be described.
pub fn describe_silhouette(name: &str, img: &GrayImage, params: &Params) -> Result<Described, String> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut labels: Vec<u8> = img.as_raw().iter().map(|&p| (p > 127) as u8).collect();
    let mut store = Box::new(ContourStore::<HOST_POINTS, HOST_CONTOURS>::new());
    trace_borders(
        &mut labels,
        w,
        h,
        BorderFilter {
            min_points: 1,
            min_area: 0.0,
        },
        &mut store,
    )
    .map_err(|e| e.to_string())?;
    let best = store.largest_outer().ok_or("no part in the silhouette")?;
    let border = store.points(best);
    let mut pts = vec![[0.0f32; 2]; params.n];
    resample(border, &mut pts).map_err(|e| e.to_string())?;
    let mut part = vec![0.0f32; params.n];
    describe(&pts, params.descriptor(params.n), &mut part).map_err(|e| e.to_string())?;
    let holes = store.holes_of(best).map(|i| store.points(i));
    let template = Box::new(Template::<HOST_M>::from_border(border, holes, params).map_err(|e| e.to_string())?);
    Ok(Described {
        name: name.to_string(),
        part,
        template,
    })
}

/// The `f'` matrix and the pairs too alike to tell apart.
#[derive(Debug, Clone, Serialize)]
pub struct Similarity {
    /// Names, in row/column order.
    pub names: Vec<String>,
    /// `f'[i][j]`: silhouette `i` as a part against `j` as a template.
    pub matrix: Vec<Vec<f32>>,
    /// `ε` the warnings use.
    pub epsilon: f32,
    /// Pairs `(i, j, min(f'[i][j], f'[j][i]))` with `i < j` below `ε`.
    pub too_alike: Vec<(usize, usize, f32)>,
    /// Each silhouette's [`vorl_core::Template::mirror_gap`]: from
    /// [`vorl_core::library::template::CHIRAL_GAP`] on it is chiral, and a part lying upside down is its
    /// mirror image (which detect matches too, reporting it `flipped`).
    pub mirror_gap: Vec<f32>,
}

/// Checks that every silhouette holds one part, describes it and fills the matrix in parallel;
/// `progress` is called once per finished row.
///
/// # Errors
/// The first silhouette that cannot be described, named.
pub fn similarity(
    silhouettes: &[NamedSilhouette],
    params: &Params,
    progress: &(dyn Fn() + Sync),
) -> Result<Similarity, String> {
    let described: Vec<Described> = silhouettes
        .par_iter()
        .map(|s| {
            crate::engine::check_silhouette(&s.image)
                .and_then(|_| describe_silhouette(&s.name, &s.image, params))
                .map_err(|e| format!("{}: {e}", s.path.display()))
        })
        .collect::<Result<_, _>>()?;
    let width = vorl_core::shape::matching::search_cells(params.n, params.m).max(params.m - params.n + 1);
    let matrix: Vec<Vec<f32>> = described
        .par_iter()
        .map(|a| {
            let mut row = vec![0.0f32; width];
            let r = described
                .iter()
                .map(|b| {
                    best_cost(&a.part, b.template.descriptor(), f32::INFINITY, &mut row)
                        .ok()
                        .flatten()
                        .map_or(f32::INFINITY, |m| m.normalized)
                })
                .collect();
            progress();
            r
        })
        .collect();
    let mut too_alike = Vec::new();
    for (i, row) in matrix.iter().enumerate() {
        for (j, &v_ij) in row.iter().enumerate().skip(i + 1) {
            let v = v_ij.min(matrix[j][i]);
            if v < params.epsilon {
                too_alike.push((i, j, v));
            }
        }
    }
    let mirror_gap = described.iter().map(|d| d.template.mirror_gap()).collect();
    Ok(Similarity {
        mirror_gap,
        names: described.into_iter().map(|d| d.name).collect(),
        matrix,
        epsilon: params.epsilon,
        too_alike,
    })
}

impl Similarity {
    /// The matrix as CSV: a header row of names, then one row per silhouette.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("part\\template");
        for n in &self.names {
            s.push(',');
            s.push_str(&csv_field(n));
        }
        s.push('\n');
        for (n, row) in self.names.iter().zip(&self.matrix) {
            s.push_str(&csv_field(n));
            for v in row {
                s.push_str(&format!(",{v:.5}"));
            }
            s.push('\n');
        }
        s
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
