//! vorl-core (placeholder while the skeleton is laid out).
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
