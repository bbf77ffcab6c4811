//! # vorl-core
//!
//! Allocation-free, `no_std`, panic-free contour matching for smart cameras: which taught part
//! lies on the platform (or that it is unknown), where its centre is and how far it is turned,
//! following *Vision-Based Object Fuzzy Recognition in Plain Industrial Environment by Contour
//! Matching* (the paper in `shared/paper`).
//!
//! ## Data flow: one folder per stage
//!
//! The stages, in the order a frame goes through them (each folder's first paragraph says what
//! it does and why; a stable `cargo doc` lists the folders alphabetically, `bash scripts/doc.sh`
//! — nightly rustdoc's `--sort-modules-by-appearance`, as docs.rs is set up to — in this order):
//!
//! 1. [`pixels`] — frame → foreground mask: enhancement, the platform (empty shots or estimated),
//!    exposure, threshold and clean-up.
//! 2. [`borders`] — mask → ordered outlines with their holes, resampled by arc length.
//! 3. [`shape`] — outline → descriptor → the cyclic DP match against each template.
//! 4. [`pose`] — match → rotation, alignment and verification, holes, position.
//! 5. [`recognizer`] — the stages together, one part at a time: candidates, verdict, and the
//!    partial search of touching parts ([`recognizer::split`]).
//! 6. [`location`] — after recognition: stereo height and the camera-to-robot fit.
//!
//! Beside the flow: [`library`] (templates and their flash format), [`params`], [`budget`]
//! (the memory a configuration needs), [`error`] and [`math`] (the one door to `libm`).
//!
//! ```text
//! frame (u8 gray)                                   pixels::frame::Frame
//!  → edge-enhanced intensity I' = α·I + (1−α)·|∇I|  pixels::enhance      (eq. 3.1)
//!  → difference to the mean background of I'        pixels::background   (3.2)
//!    (or to the platform estimated from the frame,  pixels::platform
//!    its exposure fitted)                           pixels::exposure
//!  → mask |I' − B| > τ (fixed or Otsu), 3×3 clean-up pixels::mask
//!  → ordered borders, Suzuki–Abe                    borders::contour     (3.3)
//!  → n (part) / m (template) points by arc length   borders::resample    (4.5)
//!  → descriptor c_i = ω·a_i + (1−ω)·d_i              shape::descriptor    (4.1–4.3)
//!  → cyclic order-preserving DP, f' = f_min / n     shape::matching      (4.4–4.9, 5.1)
//!  → known iff f' < ε; rotation; area centroid      pose                 (5.2, 6.1–6.4)
//!  → candidates aligned and verified: the outline,  pose::refine
//!    and the template's holes where the pose puts   pose::holes
//!    them; partial-volume centroid                  pose::partial_volume
//!  → (touching_parts) a blob no template explains:  recognizer::split
//!    the parts along its border, open DP on         shape::arcs
//!    turning angles, aligned on the visible edge
//!  → detections                                     recognizer
//!  → (two cameras) height; robot coordinates        location::stereo, location::calibrate
//! ```
//!
//! ## Rules
//!
//! - `#![no_std]`, no `alloc`, no `unsafe`. Every buffer is the caller's (frame-sized planes) or
//!   a const-generic capacity ([`Recognizer`]`<T, M, P, C, D>`), so the memory a configuration
//!   needs is known before it runs (`vorl budget`).
//! - No panics on any input: bad input is an [`Error`]; a border that cannot be used is a
//!   [`recognizer::Skip`] in the [`recognizer::Report`], with its reason.
//! - `f32` throughout; only [`math`] names `libm`.
//!
//! The std reference implementation in `vorl-host-sim` is written independently from the same
//! paper and `docs/pipeline-spec.md`; the tests hold the two against each other.

#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
// `!(x > 0.0)` is the NaN-safe guard used throughout (NaN fails every comparison, so the guard
// rejects it); clippy's preferred `x <= 0.0` would let NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// The stages in data-flow order (rustdoc keeps this order with `--sort-modules-by-appearance`).
pub mod pixels;
pub mod borders;
pub mod shape;
pub mod pose;
pub mod recognizer;
pub mod location;

pub mod library;
pub mod params;
pub mod budget;
pub mod error;
pub mod math;
#[cfg(test)]
mod test_rng;
// The test-support module names the crate as the benchmarks do.
#[cfg(test)]
extern crate self as vorl_core;
#[cfg(test)]
mod test_support;

pub use error::{Error, Result};
pub use library::template::{NearTurn, Template, Tolerance};
pub use params::{AngleEstimator, Params, Position, Refine};
pub use pixels::background::Background;
pub use pixels::frame::{Frame, FrameBuffer};
pub use recognizer::{Detection, Recognizer, Report};
