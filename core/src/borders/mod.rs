//! Mask to outlines: the second stage (paper §3.3, §4.5). The mask's borders are followed in
//! raster order, Suzuki–Abe, into ordered point lists with their hole hierarchy
//! ([`contour`]); each kept border is resampled to a fixed number of points by arc length
//! ([`resample`]) for the shape stage.
//!
//! The borders live in a caller-sized [`contour::ContourStore`] (its capacity in points and
//! contours is a const generic), so the stage never allocates and a frame with more than it
//! holds is reported, not truncated silently.

pub mod contour;
pub mod resample;
