//! Host side of vorl: PNG I/O, the independent std reference implementation, the fixture
//! generator and the pieces of the `vorl` command-line program.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod cli;
pub mod compare;
pub mod config;
pub mod engine;
pub mod eval;
pub mod gen;
pub mod io;
pub mod overlay;
pub mod reference;
pub mod run;
pub mod serve;
pub mod set;
pub mod similarity;
pub mod soak;
pub mod teaching;
pub mod truth;
