//! Tests of the real-camera variants and of sets without a background.

use super::render::Texture;
use super::tests::{files, gray, scratch, worst_disagreement};
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

/// Frame `index` of a set without noise or drift: the plan, its placed parts, the image before
/// noise and the blurred empty platform.
fn clean_frame(opts: &GenOptions, index: usize) -> (SetPlan, Vec<Placed>, Vec<f64>, Vec<f64>) {
    let mut set = SetPlan::new(opts);
    set.drift_max = 0.0;
    let mut rng = Rng::stream(opts.seed, purpose::LAYOUT, index as u64);
    let parts = plan(&mut rng, &set.cat, &set.scene);
    let img = set.compose(&parts, false, &mut rng);
    let mut light = set.light.clone();
    blur(&mut light, set.w, set.h, BLUR_SIGMA);
    (set, parts, img, light)
}

/// Centroid of `weight(i)` over the pixels within `r` of `c`.
fn centroid(w: usize, h: usize, c: P, r: f64, weight: impl Fn(usize) -> f64) -> P {
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    let (y0, y1) = (
        (c[1] - r).floor().max(0.0) as usize,
        ((c[1] + r).ceil() as usize).min(h - 1),
    );
    let (x0, x1) = (
        (c[0] - r).floor().max(0.0) as usize,
        ((c[0] + r).ceil() as usize).min(w - 1),
    );
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (x as f64 - c[0]).hypot(y as f64 - c[1]) <= r {
                let v = weight(y * w + x);
                s += v;
                sx += v * x as f64;
                sy += v * y as f64;
            }
        }
    }
    [sx / s, sy / s]
}

type P = [f64; 2];

fn dist(a: P, b: P) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn truth_of(dir: &Path) -> FramesJson {
    FramesJson::load(&dir.join("truth.json")).expect("truth loads")
}

fn variant_json(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("variant.json")).expect("variant.json")).expect("json")
}

#[test]
fn gen_real_variants_are_deterministic_and_write_their_fields() {
    let fields: [(Variant, &[&str]); 1] = [(Variant::Sharp, &[])];
    for (v, want) in fields {
        let opts = small_opts(v, 4, 3);
        let (a, b, c) = (
            scratch(&format!("{v}-a")),
            scratch(&format!("{v}-b")),
            scratch(&format!("{v}-c")),
        );
        let sa = generate(&a, &opts).expect("generate a");
        let sb = generate(&b, &opts).expect("generate b");
        generate(
            &c,
            &GenOptions {
                seed: 5,
                ..opts.clone()
            },
        )
        .expect("generate c");
        assert_eq!(sa, sb, "{v}");
        assert!(sa.parts >= 2, "{v}: {sa:?}");
        let (fa, fb) = (files(&a), files(&b));
        assert_eq!(fa, fb, "{v}: same options, same bytes");
        assert_ne!(
            std::fs::read(a.join("truth.json")).ok(),
            std::fs::read(c.join("truth.json")).ok(),
            "{v}"
        );
        assert_eq!(variant_json(&a)["variant"], json!(v.name()));
        assert!(a.join("background.png").is_file(), "{v}");
        let classes: Vec<String> = v
            .catalogue()
            .iter()
            .filter(|s| s.is_template)
            .map(|s| s.name.to_string())
            .collect();
        assert_eq!(sa.classes, classes);
        for t in classes {
            assert!(a.join("templates").join(format!("{t}.png")).is_file(), "{v}: {t}");
        }
        for parts in truth_of(&a).frames.values() {
            for p in parts {
                assert!((0.0..360.0).contains(&p.angle_deg), "{v}");
                for key in ["scale", "contrast", "texture", "shape"].iter().chain(want) {
                    assert!(p.extra.contains_key(*key), "{v}: {key} missing");
                }
                assert!(p.symmetry.is_some());
            }
        }
        for d in [a, b, c] {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}

#[test]
fn gen_sharp_parts_centroids_and_silhouettes_match_truth() {
    let opts = GenOptions {
        seed: 8,
        frames: 3,
        variant: Variant::Sharp,
        ..GenOptions::default()
    };
    let mut checked = 0;
    for index in 0..8 {
        let (set, parts, img, light) = clean_frame(&opts, index);
        for p in parts.iter().filter(|p| p.look.texture == Texture::Plain) {
            let r = set.cat[p.spec].radius_mm() * p.pose.k + 4.0;
            let c = centroid(set.w, set.h, [p.pose.cx, p.pose.cy], r, |i| {
                (img[i] - light[i]) / p.look.contrast
            });
            let t = truth_entry(&set.cat[p.spec], p);
            assert!(dist(c, [t.x, t.y]) < 0.02, "{}: {c:?}", set.cat[p.spec].name);
            checked += 1;
        }
    }
    assert!(checked >= 5);
    let dir = scratch("sharp-set");
    generate(&dir, &opts).expect("generate");
    let bg = gray(&dir.join("background.png"));
    for (name, parts) in &truth_of(&dir).frames {
        for p in parts {
            assert!(sharp_catalogue()
                .iter()
                .any(|s| Some(s.name) == p.extra["shape"].as_str()));
        }
        let worst = worst_disagreement(&gray(&dir.join("frames").join(name)), &bg, parts, false);
        assert!(worst < 0.005, "{name}: {worst}");
    }
    let t = gray(&dir.join("templates").join("gear_sharp_z12.png"));
    assert!(t.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn gen_no_background_leaves_out_only_the_platform() {
    for v in [Variant::Default, Variant::Stereo, Variant::Sharp] {
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
            s.starts_with("background") || s == "variant.json"
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
