//! Hands the workspace's top-level `memory.x` to the linker (cortex-m-rt's `link.x` includes
//! it) and rebuilds when it changes.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let memory = manifest.join("..").join("memory.x");
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let text = fs::read(&memory).unwrap_or_else(|e| panic!("{}: {e}", memory.display()));
    fs::write(out.join("memory.x"), text).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    println!("cargo:rerun-if-changed=build.rs");
}
