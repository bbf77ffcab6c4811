//! Pixels to mask: the first stage of the data flow (paper §3.1–3.2). A gray frame
//! ([`frame`]) is edge-enhanced ([`enhance`], eq. 3.1), compared with the platform it lies on
//! — the mean of empty shots ([`background`], eq. 3.2), the frame's gain and offset fitted to
//! it on its platform pixels ([`exposure`]), or without a shot, the platform estimated from the
//! frame itself ([`platform`]) — and thresholded into the foreground mask ([`mask`]) that the
//! border stage follows. Taking both signs, the recognizer cuts a bright part's shadow off it
//! once the borders are known ([`shadow`]), and follows them again.
//!
//! Everything here works row by row over caller-owned planes of the frame's size: no
//! allocation, `O(width·height)` time, a fixed stack of a few KiB at most (histograms, the
//! mask's row spans; the platform estimate's cells are the caller's grid).

pub mod background;
pub mod enhance;
pub mod exposure;
pub mod frame;
pub mod mask;
pub mod platform;
pub mod shadow;
