//! # vorl-core
//!
//! Allocation-free, `no_std`, panic-free contour matching for smart cameras: which taught part
//! lies on the platform (or that it is unknown), where its centre is and how far it is turned,
//! following *Vision-Based Object Fuzzy Recognition in Plain Industrial Environment by Contour
//! Matching* (the paper in `shared/paper`).
//!
//! ## Data flow, one module per stage
//!
//! ```text
//! frame (u8 gray)                                   frame::Frame
//!  → edge-enhanced intensity I' = α·I + (1−α)·|∇I|  enhance      (eq. 3.1)
//!  → difference to the mean background of I'        background   (3.2)
//!    (or to the platform estimated from the frame)  platform
//!  → mask |I' − B| > τ (fixed or Otsu), 3×3 clean-up mask
//!  → ordered borders, Suzuki–Abe                    contour      (3.3)
//!  → n (part) / m (template) points by arc length   resample     (4.5)
//!  → descriptor c_i = ω·a_i + (1−ω)·d_i              descriptor   (4.1–4.3)
//!  → cyclic order-preserving DP, f' = f_min / n     matching     (4.4–4.9, 5.1)
//!  → known iff f' < ε; rotation; area centroid      pose         (5.2, 6.1–6.4)
//!  → candidates aligned and verified: the outline,  refine
//!    and the template's holes where the pose puts   holes
//!    them; partial-volume centroid                  partial_volume
//!  → (touching_parts) a blob no template explains:  split
//!    the parts along its border, open DP on         arcs
//!    turning angles, aligned on the visible edge
//!  → detections                                     recognizer
//! ```
//!
//! ## Rules
//!
//! - `#![no_std]`, no `alloc`, no `unsafe`. Every buffer is the caller's (frame-sized planes) or
//!   a const-generic capacity ([`Recognizer`]`<T, M, P, C, D>`), so the memory a configuration
//!   needs is known before it runs (`vorl budget`).
//! - No panics on any input: bad input is an [`Error`]; a border that cannot be used is a
//!   [`recognizer::Skip`] in the [`recognizer::Report`], with its reason.
//! - `f32` throughout; only `math` names `libm`.
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

pub mod arcs;
pub mod background;
pub mod budget;
pub mod calibrate;
pub mod contour;
pub mod descriptor;
pub mod enhance;
pub mod error;
pub mod exposure;
pub mod frame;
pub mod holes;
pub mod library;
pub mod mask;
pub mod matching;
pub mod math;
pub mod params;
pub mod partial_volume;
pub mod platform;
pub mod pose;
pub mod recognizer;
pub mod refine;
pub mod resample;
pub mod split;
pub mod stereo;
pub mod template;
#[cfg(test)]
mod test_rng;

pub use background::Background;
pub use error::{Error, Result};
pub use frame::{Frame, FrameBuffer};
pub use params::{AngleEstimator, Params, Position, Refine};
pub use recognizer::{Detection, Recognizer, Report};
pub use template::{Template, Tolerance};
