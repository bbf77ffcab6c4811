//! Outline to match: the third stage (paper §4–5). Each resampled outline gets its per-point
//! descriptor ([`descriptor`], eqs. 4.1–4.3), and the part's descriptor is matched against each
//! template's by the cyclic order-preserving dynamic programme over every start
//! ([`matching`], eqs. 4.4–4.9, 5.1), whose normalised cost `f′` decides which template the
//! part is. [`arcs`] matches an open stretch of outline (a part seen only in part, against
//! another) by turning angle.
//!
//! The DP's table is the caller's `f32` buffer ([`matching::table_cells`]); its time is
//! `O(n·m·log m)` per search.

pub mod arcs;
pub mod descriptor;
pub mod matching;
