//! Host side of vorl: PNG I/O, the independent std reference implementation, the fixture
//! generator and the pieces of the `vorl` command-line program.

#![forbid(unsafe_code)]

pub mod gen;
pub mod reference;
