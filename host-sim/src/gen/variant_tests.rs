//! Tests of sets without a background.

use super::tests::{files, scratch};
use super::*;

/// A 320×240 set of `frames` frames of `variant`.
fn small_opts(variant: Variant, seed: u64, frames: usize) -> GenOptions {
    GenOptions {
        seed,
        frames,
        variant,
        width: 320,
        height: 240,
        background: None,
    }
}

#[test]
fn gen_no_background_leaves_out_only_the_platform() {
    for v in [Variant::Default, Variant::Stereo] {
        let (with, without) = (scratch(&format!("bg-{v}")), scratch(&format!("nobg-{v}")));
        generate(&with, &small_opts(v, 3, 2)).expect("generate");
        generate(
            &without,
            &GenOptions {
                background: Some(false),
                ..small_opts(v, 3, 2)
            },
        )
        .expect("generate");
        let platform = |p: &Path| {
            let s = p.to_string_lossy();
            s.starts_with("background")
        };
        let keep = |f: Vec<(PathBuf, Vec<u8>)>| f.into_iter().filter(|(p, _)| !platform(p)).collect::<Vec<_>>();
        let (fw, fo) = (files(&with), files(&without));
        assert!(
            fo.iter().all(|(p, _)| !p.to_string_lossy().starts_with("background")),
            "{v}"
        );
        assert!(fw.iter().any(|(p, _)| p == Path::new("background.png")));
        assert_eq!(keep(fw), keep(fo), "{v}: frames, templates and truth do not change");
        for d in [with, without] {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}
