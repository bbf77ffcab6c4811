//! Tests of the real-camera variants and of sets without a background.

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
    let scene = set.scene_of(index);
    let mut rng = Rng::stream(opts.seed, purpose::LAYOUT, scene as u64);
    let mut parts = set.plan(&mut rng);
    set.finish_parts(&mut parts, scene);
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
    let fields: [(Variant, &[&str]); 11] = [
        (Variant::Sharp, &[]),
        (
            Variant::Lens,
            &[
                "x_undistorted",
                "y_undistorted",
                "angle_drawn_deg",
                "lens_rotation_deg",
                "lens_scale",
                "area_x",
                "area_y",
            ],
        ),
        (
            Variant::Thick,
            &["thickness_mm", "top_scale", "bottom_x", "bottom_y", "wall_contrast"],
        ),
        (Variant::Exposure, &["gain", "offset", "scene"]),
        (Variant::Paper, &[]),
        (Variant::Printed, &[]),
        (Variant::Backlit, &["level"]),
        (Variant::Rods, &["level", "stretch"]),
        (Variant::Large, &["level"]),
        (Variant::RodsTouching, &["level", "stretch"]),
        (
            Variant::Frontlit,
            &[
                "light_from_deg",
                "shadow_dx",
                "shadow_dy",
                "shadow_sigma",
                "shadow_depth",
                "facet",
                "facet_share",
                "facet_level",
                "highlights",
            ],
        ),
    ];
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
        assert_eq!(a.join("background.png").is_file(), v.writes_background(), "{v}");
        assert_eq!(a.join("vorl.toml").is_file(), v.set_config().is_some(), "{v}");
        assert_eq!(a.join("teach.json").is_file(), v.writes_teach(), "{v}");
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
            let t = set.truth(p, index);
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
    for name in ["gear_sharp_z12", "gear_sharp_z10"] {
        let t = gray(&dir.join("templates").join(format!("{name}.png")));
        assert!(t.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255), "{name}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn gen_lens_truth_is_the_distorted_centroid() {
    let opts = GenOptions {
        seed: 12,
        frames: 6,
        variant: Variant::Lens,
        ..GenOptions::default()
    };
    let (mut checked, mut turned) = (0, 0.0_f64);
    for index in 0..6 {
        let (set, parts, img, light) = clean_frame(&opts, index);
        let Effect::Lens(lens) = &set.effect else {
            panic!("lens variant without a lens");
        };
        let shift = lens.corner_shift(set.w, set.h);
        assert!((3.0..6.0).contains(&shift), "{shift}");
        for p in &parts {
            let t = set.truth(p, index);
            let spec = &set.cat[p.spec];
            let area_c = [
                t.extra["area_x"].as_f64().expect("x"),
                t.extra["area_y"].as_f64().expect("y"),
            ];
            // The distorted image of the centroid is the centroid of the distorted silhouette to
            // first order (the scale varies over the part: up to about 0.2 px near the corners).
            let off = dist(area_c, [t.x, t.y]);
            assert!(off < 0.3, "{}: {area_c:?} vs {} {}", spec.name, t.x, t.y);
            assert!(
                off <= 0.01 + 0.002 * dist([t.x, t.y], lens.centre),
                "{}: {off}",
                spec.name
            );
            let rot = t.extra["lens_rotation_deg"].as_f64().expect("rot");
            assert!(rot.abs() < 1.0, "{rot}");
            assert!((wrap_deg(p.angle_deg + rot) - t.angle_deg).abs() < 1e-9);
            turned = turned.max(rot.abs());
            if p.look.texture == Texture::Plain {
                let r = spec.radius_mm() * p.pose.k + 4.0;
                let c = centroid(set.w, set.h, [t.x, t.y], r, |i| (img[i] - light[i]) / p.look.contrast);
                assert!(dist(c, area_c) < 0.02, "{}: rendered {c:?} vs {area_c:?}", spec.name);
                checked += 1;
            }
            // Scale a little under 1 (barrel), not the drawn one.
            let s = t.extra["lens_scale"].as_f64().expect("scale");
            assert!(s < 1.0 && s > 0.95, "{s}");
        }
    }
    assert!(checked >= 3, "{checked}");
    assert!(turned > 0.001, "some part is turned by the lens: {turned}");
}

#[test]
fn gen_thick_parts_show_their_walls_and_truth_is_the_top_face() {
    let opts = GenOptions {
        seed: 6,
        frames: 6,
        variant: Variant::Thick,
        ..GenOptions::default()
    };
    let mut outward = 0;
    for index in 0..6 {
        let (set, parts, img, light) = clean_frame(&opts, index);
        let Effect::Thick(cam) = set.effect else {
            panic!("thick variant without a close camera");
        };
        for p in &parts {
            let t = set.truth(p, index);
            let Body::Thick { thickness_mm, wall } = p.body else {
                panic!("flat part in a thick set");
            };
            assert!((THICKNESS_MM.0..THICKNESS_MM.1).contains(&thickness_mm));
            let s = cam.scale(thickness_mm);
            assert!((t.extra["top_scale"].as_f64().expect("s") - s).abs() < 1e-12);
            assert!((t.extra["scale"].as_f64().expect("scale") - p.scale * s).abs() < 1e-12);
            // The top face's centroid is the bottom's magnified about the principal point.
            let top = cam.lift_point([p.pose.cx, p.pose.cy], s);
            assert!(dist(top, [t.x, t.y]) < 1e-9);
            let spec = &set.cat[p.spec];
            let top_pose = raster::Pose::new(t.x, t.y, t.angle_deg, t.extra["scale"].as_f64().expect("scale"));
            let top_cov = silhouette(spec, &top_pose, set.w, set.h);
            let (top_area, top_c) = top_cov.moments();
            assert!(dist(top_c, [t.x, t.y]) < 0.02);
            let sweep = coverage_union(&cam.sweep(&p.pose.rings(spec.rings()), s), None, SUBROWS);
            let (area, c) = sweep.moments();
            assert!(area > top_area);
            // Every pixel of the top face is in the sweep.
            top_cov.for_each(|x, y, v| assert!(sweep.at(x, y) >= v - 1e-9));
            // Seen from the principal point, the walls lie on the near side: the part's image
            // is stretched outward from its top face towards the centre.
            if dist(top, cam.centre) > 60.0 {
                let (u, d) = (
                    [cam.centre[0] - top[0], cam.centre[1] - top[1]],
                    [c[0] - top[0], c[1] - top[1]],
                );
                assert!(u[0] * d[0] + u[1] * d[1] > 0.0);
                outward += 1;
            }
            // The rendered part: the sweep at the wall level plus the top face at its own.
            if p.look.texture == Texture::Plain {
                // Within the room the placement kept for the part (its walls included) + 3.5 px.
                let bottom = [p.pose.cx, p.pose.cy];
                let r = s * spec.radius_mm() * p.pose.k + dist(bottom, cam.centre) * (s - 1.0) + 3.5;
                let got = centroid(set.w, set.h, bottom, r, |i| img[i] - light[i]);
                let want = [
                    (wall * area * c[0] + (p.look.contrast - wall) * top_area * top_c[0])
                        / (wall * area + (p.look.contrast - wall) * top_area),
                    (wall * area * c[1] + (p.look.contrast - wall) * top_area * top_c[1])
                        / (wall * area + (p.look.contrast - wall) * top_area),
                ];
                assert!(dist(got, want) < 0.03, "{}: {got:?} vs {want:?}", spec.name);
            }
        }
    }
    assert!(outward >= 5);
}

#[test]
fn gen_exposure_pairs_show_one_scene_at_two_exposures() {
    let dir = scratch("exposure");
    let opts = GenOptions {
        seed: 2,
        frames: 5,
        variant: Variant::Exposure,
        ..GenOptions::default()
    };
    generate(&dir, &opts).expect("generate");
    let truth = truth_of(&dir);
    let names: Vec<&String> = truth.frames.keys().collect();
    let exposure = |n: &str| {
        let p = &truth.frames[n][0];
        (
            p.extra["gain"].as_f64().expect("gain"),
            p.extra["offset"].as_f64().expect("offset"),
            p.extra["scene"].as_u64().expect("scene"),
        )
    };
    for (i, n) in names.iter().enumerate() {
        let (g, o, scene) = exposure(n);
        assert!((EXPOSURE_GAIN.0..EXPOSURE_GAIN.1).contains(&g) && (EXPOSURE_OFFSET.0..EXPOSURE_OFFSET.1).contains(&o));
        assert_eq!(scene, i as u64 / 2);
    }
    for k in 0..2 {
        let (a, b) = (names[2 * k], names[2 * k + 1]);
        let (ga, oa, _) = exposure(a);
        let (gb, ob, _) = exposure(b);
        assert!((ga - gb).abs() >= EXPOSURE_GAIN_STEP);
        // Same parts at the same poses.
        let pose = |n: &str| -> Vec<(Option<String>, f64, f64, f64)> {
            truth.frames[n]
                .iter()
                .map(|p| (p.class.clone(), p.x, p.y, p.angle_deg))
                .collect()
        };
        assert_eq!(pose(a), pose(b));
        // Undone, the two exposures agree to the noise (where neither clips).
        let (fa, fb) = (gray(&dir.join("frames").join(a)), gray(&dir.join("frames").join(b)));
        let (mut undone, mut raw, mut n) = (0.0, 0.0, 0.0);
        for (pa, pb) in fa.pixels().zip(fb.pixels()) {
            let (va, vb) = (f64::from(pa.0[0]), f64::from(pb.0[0]));
            if (3.0..252.0).contains(&va) && (3.0..252.0).contains(&vb) {
                undone += ((va - oa) / ga - (vb - ob) / gb).abs();
                raw += (va - vb).abs();
                n += 1.0;
            }
        }
        // Mean |difference| of two Gaussian noises of σ = 2/ga and 2/gb, plus rounding.
        let expected = 2.0 * (1.0 / (ga * ga) + 1.0 / (gb * gb)).sqrt() * (2.0 / std::f64::consts::PI).sqrt();
        assert!(undone / n < 1.2 * expected + 0.3, "{} vs {expected}", undone / n);
        assert!(raw / n > undone / n, "{} {}", raw / n, undone / n);
    }
    // The background at gain 1.
    let bg = gray(&dir.join("background.png"));
    let mean = bg.pixels().map(|p| f64::from(p.0[0])).sum::<f64>() / (640.0 * 480.0);
    assert!((110.0..=150.0).contains(&mean), "{mean}");
    let _ = std::fs::remove_dir_all(dir);
}

/// Fine detail of an image: each pixel less the mean of the 7×7 pixels about it.
fn detail(img: &image::GrayImage) -> Vec<f64> {
    let (w, h) = (i64::from(img.width()), i64::from(img.height()));
    let at = |x: i64, y: i64| f64::from(img.get_pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32).0[0]);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let mut s = 0.0;
            for dy in -3..=3 {
                for dx in -3..=3 {
                    s += at(x + dx, y + dy);
                }
            }
            at(x, y) - s / 49.0
        })
        .collect()
}

#[test]
fn gen_paper_texture_is_part_of_the_platform() {
    let dir = scratch("paper");
    let opts = small_opts(Variant::Paper, 3, 2);
    generate(&dir, &opts).expect("generate");
    let (bg, bg0) = (
        gray(&dir.join("background.png")),
        gray(&dir.join("backgrounds").join("bg_00.png")),
    );
    let std = variant_json(&dir)["texture_std"].as_f64().expect("std");
    assert!((PAPER_STD.0..PAPER_STD.1).contains(&std));
    // Fine detail of two captures of the platform: the same texture under fresh noise.
    let (a, b) = (detail(&bg), detail(&bg0));
    let (sa, sb) = (effects::spread(&a).1, effects::spread(&b).1);
    let corr = a.iter().zip(&b).map(|(x, y)| x * y).sum::<f64>() / a.len() as f64 / (sa * sb);
    assert!(corr > 0.5, "texture shared by the captures: {corr}");
    assert!(sa > 2.0, "texture visible: {sa}");
    // Inside a plain part the texture is hidden; outside, the frame is the platform.
    let (set, parts, img, light) = clean_frame(&opts, 0);
    let Effect::Paper { texture, .. } = &set.effect else {
        panic!("paper variant without texture");
    };
    let mut bare: Vec<f64> = set.light.iter().zip(texture).map(|(l, t)| l - t).collect();
    blur(&mut bare, set.w, set.h, BLUR_SIGMA);
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    // Pixels within 3 px of a part.
    let mut near = vec![false; set.w * set.h];
    for p in &parts {
        let cov = silhouette(&set.cat[p.spec], &p.pose, set.w, set.h);
        cov.for_each(|x, y, _| {
            for dy in -3..=3_i64 {
                for dx in -3..=3_i64 {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx >= 0 && yy >= 0 && (xx as usize) < set.w && (yy as usize) < set.h {
                        near[yy as usize * set.w + xx as usize] = true;
                    }
                }
            }
        });
        if p.look.texture != Texture::Plain {
            continue;
        }
        cov.for_each(|x, y, _| {
            // Pixels 3 px or more inside the part.
            let deep = (-3..=3).all(|dy: i64| (-3..=3).all(|dx: i64| cov.at(x + dx, y + dy) == 1.0));
            if deep {
                let i = y as usize * set.w + x as usize;
                inside.push(img[i] - bare[i] - p.look.contrast);
            }
        });
    }
    for (i, (v, l)) in img.iter().zip(&light).enumerate() {
        if !near[i] {
            outside.push(v - l);
        }
    }
    assert!(!inside.is_empty());
    assert!(effects::spread(&inside).1 < 0.5, "texture hidden under parts");
    // Away from the parts the frame is the textured platform.
    let off = effects::spread(&outside);
    assert!(off.0.abs() < 1e-9 && off.1 < 1e-9, "{off:?}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn gen_printed_parts_keep_their_own_centroid() {
    let opts = GenOptions {
        seed: 4,
        frames: 6,
        variant: Variant::Printed,
        ..GenOptions::default()
    };
    let (mut printed, mut patches) = (0, 0);
    for index in 0..6 {
        let (set, parts, img, _) = clean_frame(&opts, index);
        for p in &parts {
            let t = set.truth(p, index);
            let spec = &set.cat[p.spec];
            let (_, c) = silhouette(spec, &p.pose, set.w, set.h).moments();
            assert!(dist(c, [t.x, t.y]) < 0.02);
            let Texture::Print { marks } = &p.look.texture else {
                continue;
            };
            printed += 1;
            patches += t.extra["print_patches"].as_u64().expect("patches");
            assert_eq!(t.extra["texture"], json!("print"));
            assert_eq!(
                t.extra["print_marks"].as_u64().expect("marks") + t.extra["print_patches"].as_u64().expect("patches"),
                marks.len() as u64
            );
            // The print is there: the part's pixels are far from one level.
            let mut plain = p.clone();
            plain.look.texture = Texture::Plain;
            let mut flat = set.light.clone();
            draw_part(&mut flat, set.w, set.h, spec, &plain.pose, &plain.look);
            blur(&mut flat, set.w, set.h, BLUR_SIGMA);
            let differ = (0..set.w * set.h).filter(|&i| (img[i] - flat[i]).abs() > 15.0).count();
            assert!(differ > 10, "{}: {differ} printed pixels", spec.name);
        }
    }
    assert!(printed >= 6 && patches >= 1, "{printed} {patches}");
}

#[test]
fn gen_backlit_parts_are_dark_on_a_vignetted_backlight() {
    let opts = GenOptions {
        seed: 9,
        frames: 4,
        variant: Variant::Backlit,
        ..GenOptions::default()
    };
    let mut checked = 0;
    for index in 0..4 {
        let (set, parts, img, light) = clean_frame(&opts, index);
        let Effect::Backlit(b) = &set.effect else {
            panic!("backlit variant without a backlight");
        };
        assert!((244.0..252.0).contains(&light[(set.h / 2) * set.w + set.w / 2]));
        let corners = [0, set.w - 1, (set.h - 1) * set.w, set.h * set.w - 1];
        let darkest = corners.iter().map(|&i| set.light[i]).fold(f64::MAX, f64::min);
        assert!((145.0..155.0).contains(&darkest), "{darkest}");
        assert!((darkest - b.corner_level(set.w, set.h)).abs() < 1e-9);
        for p in &parts {
            let t = set.truth(p, index);
            let Body::Opaque { level } = p.body else {
                panic!("a backlit part that is not opaque");
            };
            assert_eq!(t.extra["level"], json!(level));
            // Opaque: the part's share of each pixel is (backlight − image) / (backlight − level).
            let r = set.cat[p.spec].radius_mm() * p.pose.k + 4.0;
            let c = centroid(set.w, set.h, [t.x, t.y], r, |i| {
                (light[i] - img[i]) / (light[i] - level)
            });
            assert!(dist(c, [t.x, t.y]) < 0.03, "{c:?} vs {} {}", t.x, t.y);
            checked += 1;
        }
    }
    assert!(checked >= 6);
    // No background unless asked for.
    let dir = scratch("backlit");
    generate(&dir, &small_opts(Variant::Backlit, 9, 1)).expect("generate");
    assert!(!dir.join("background.png").exists() && !dir.join("backgrounds").exists());
    assert_eq!(variant_json(&dir)["background"], json!(false));
    generate(
        &dir,
        &GenOptions {
            background: Some(true),
            ..small_opts(Variant::Backlit, 9, 1)
        },
    )
    .expect("generate");
    assert!(dir.join("background.png").is_file() && dir.join("backgrounds").join("bg_07.png").is_file());
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn gen_no_background_leaves_out_only_the_platform() {
    for v in [
        Variant::Default,
        Variant::Stereo,
        Variant::Lens,
        Variant::Frontlit,
        Variant::Large,
    ] {
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

/// The holes of a binary template (255 on 0): the 0 pixels that the 0 pixels on the image's
/// border do not reach (4-connected), as components, each its pixels.
fn holes(t: &image::GrayImage) -> Vec<Vec<(i64, i64)>> {
    let (w, h) = (i64::from(t.width()), i64::from(t.height()));
    let empty = |x: i64, y: i64| t.get_pixel(x as u32, y as u32).0[0] == 0;
    // 0: not visited; 1: outside; 2 + k: hole k.
    let mut mark = vec![0usize; (w * h) as usize];
    let flood = |seed: (i64, i64), id: usize, mark: &mut [usize]| {
        let mut stack = vec![seed];
        let mut pixels = Vec::new();
        mark[(seed.1 * w + seed.0) as usize] = id;
        while let Some((x, y)) = stack.pop() {
            pixels.push((x, y));
            for (nx, ny) in [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)] {
                if nx >= 0 && ny >= 0 && nx < w && ny < h && empty(nx, ny) && mark[(ny * w + nx) as usize] == 0 {
                    mark[(ny * w + nx) as usize] = id;
                    stack.push((nx, ny));
                }
            }
        }
        pixels
    };
    for y in 0..h {
        for x in 0..w {
            let on_border = x == 0 || y == 0 || x == w - 1 || y == h - 1;
            if on_border && empty(x, y) && mark[(y * w + x) as usize] == 0 {
                flood((x, y), 1, &mut mark);
            }
        }
    }
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if empty(x, y) && mark[(y * w + x) as usize] == 0 {
                out.push(flood((x, y), 2 + out.len(), &mut mark));
            }
        }
    }
    out
}

/// The pixels of a binary template with its holes filled.
fn filled(t: &image::GrayImage) -> std::collections::BTreeSet<(i64, i64)> {
    let mut s: std::collections::BTreeSet<(i64, i64)> = t
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0[0] == 255)
        .map(|(x, y, _)| (i64::from(x), i64::from(y)))
        .collect();
    s.extend(holes(t).into_iter().flatten());
    s
}

/// Mean x of pixels.
fn mean_x(px: &[(i64, i64)]) -> f64 {
    px.iter().map(|p| p.0 as f64).sum::<f64>() / px.len() as f64
}

#[test]
fn gen_rods_templates_differ_only_in_holes() {
    let set = MemorySet::new(&small_opts(Variant::Rods, 1, 0)).expect("set");
    let templates: BTreeMap<String, image::GrayImage> = set.templates().into_iter().collect();
    assert_eq!(templates.keys().collect::<Vec<_>>(), ["rod_a", "rod_b"]);
    let (a, b) = (&templates["rod_a"], &templates["rod_b"]);
    for t in [a, b] {
        assert!(t.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255));
    }
    // The same outline: the filled silhouettes overlap (IoU) to the pixel grid's rounding, at the
    // best whole-pixel shift (the holes move the centroid the template is placed by).
    let (fa, fb) = (filled(a), filled(b));
    let mut best: f64 = 0.0;
    for dy in -2..=2 {
        for dx in -2..=2 {
            let common = fa.iter().filter(|p| fb.contains(&(p.0 + dx, p.1 + dy))).count();
            best = best.max(common as f64 / (fa.len() + fb.len() - common) as f64);
        }
    }
    assert!(best > 0.95, "outlines differ: IoU {best}");
    // The holes differ: one eye against two.
    let (ha, hb) = (holes(a), holes(b));
    assert_eq!((ha.len(), hb.len()), (1, 2));
    // At angle 0 the rod lies along x; its big end is the end with the tallest column.
    let big_end_x = |f: &std::collections::BTreeSet<(i64, i64)>| {
        let mut columns: BTreeMap<i64, usize> = BTreeMap::new();
        for p in f {
            *columns.entry(p.0).or_default() += 1;
        }
        let tallest = columns
            .iter()
            .max_by_key(|(_, n)| **n)
            .map(|(x, _)| *x as f64)
            .expect("column");
        let (x0, x1) = (
            *columns.keys().next().expect("x0") as f64,
            *columns.keys().last().expect("x1") as f64,
        );
        (tallest, (x0 + x1) / 2.0)
    };
    // rod_a's one eye is in its big end.
    let (tall, mid) = big_end_x(&fa);
    assert!(
        (mean_x(&ha[0]) - mid) * (tall - mid) > 0.0,
        "rod_a's eye not in the big end"
    );
    // rod_b: the larger eye in the big end, the smaller one in the small end.
    let (tall, mid) = big_end_x(&fb);
    let (large, small) = if hb[0].len() > hb[1].len() {
        (&hb[0], &hb[1])
    } else {
        (&hb[1], &hb[0])
    };
    assert!(large.len() > small.len() + 20, "{} {}", large.len(), small.len());
    assert!(
        (mean_x(large) - mid) * (tall - mid) > 0.0,
        "rod_b's larger eye not in the big end"
    );
    assert!(
        (mean_x(small) - mid) * (tall - mid) < 0.0,
        "rod_b's smaller eye not in the small end"
    );
}

#[test]
fn gen_rods_vary_part_to_part_and_truth_is_the_drawn_part() {
    let opts = GenOptions {
        seed: 7,
        frames: 10,
        variant: Variant::Rods,
        ..GenOptions::default()
    };
    let (mut rods, mut distractors) = (0, 0);
    let mut seen: BTreeMap<&str, (f64, f64)> = BTreeMap::new();
    for index in 0..10 {
        let (set, parts, img, light) = clean_frame(&opts, index);
        for p in &parts {
            let t = set.truth(p, index);
            let spec = p.drawn(&set.cat);
            let Body::Opaque { level } = p.body else {
                panic!("a rod that is not opaque");
            };
            let mut factors = vec!["scale", "stretch"];
            match t.class.as_deref() {
                Some("rod_a") => factors.extend(["head_big_scale", "head_small_scale", "eye_big_scale"]),
                Some("rod_b") => {
                    factors.extend(["head_big_scale", "head_small_scale", "eye_big_scale", "eye_small_scale"])
                }
                Some(other) => panic!("unexpected class {other}"),
                None => distractors += 1,
            }
            if t.class.is_some() {
                rods += 1;
                assert_eq!(t.symmetry, Some(1));
            }
            for f in factors {
                let v = t.extra[f].as_f64().expect(f);
                let e = seen.entry(f).or_insert((v, v));
                *e = (e.0.min(v), e.1.max(v));
            }
            // Truth is the area centroid of the silhouette as drawn (holes excluded): the
            // centroid of the part's share of each pixel, (backlight − image) / (backlight − level).
            let r = spec.radius_mm() * p.pose.k + 4.0;
            let c = centroid(set.w, set.h, [t.x, t.y], r, |i| {
                (light[i] - img[i]) / (light[i] - level)
            });
            assert!(dist(c, [t.x, t.y]) < 0.03, "{}: {c:?} vs {} {}", spec.name, t.x, t.y);
            // A rod's axis (its mirror line, so a principal axis of the drawn share) is the
            // template's x axis turned by angle_deg counter-clockwise on screen (y down).
            if t.class.is_some() {
                let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
                let (y0, y1) = ((t.y - r).max(0.0) as usize, ((t.y + r) as usize).min(set.h - 1));
                let (x0, x1) = ((t.x - r).max(0.0) as usize, ((t.x + r) as usize).min(set.w - 1));
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let (dx, dy) = (x as f64 - t.x, y as f64 - t.y);
                        if dx.hypot(dy) <= r {
                            let i = y * set.w + x;
                            let v = (light[i] - img[i]) / (light[i] - level);
                            sxx += v * dx * dx;
                            syy += v * dy * dy;
                            sxy += v * dx * dy;
                        }
                    }
                }
                let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
                let off = (t.angle_deg.to_radians() + phi).sin().abs().asin().to_degrees();
                assert!(off < 0.2, "{}: axis {off}° off", spec.name);
            }
        }
    }
    assert!(rods >= 15 && distractors >= 2, "{rods} rods, {distractors} distractors");
    // The spread of real rods: the shaft's length by up to about ±15 %, the heads by ±8 %, the
    // eyes by ±10 %, the size by 0.9–1.3×; the drawn parts cover most of each range and keep
    // inside it.
    for (f, lo, hi) in [
        ("scale", 0.9, 1.3),
        ("stretch", 0.85, 1.15),
        ("head_big_scale", 0.92, 1.08),
        ("head_small_scale", 0.92, 1.08),
        ("eye_big_scale", 0.9, 1.1),
        ("eye_small_scale", 0.9, 1.1),
    ] {
        let (min, max) = seen[f];
        assert!(min >= lo && max <= hi, "{f}: {min}–{max}");
        assert!(max - min > 0.6 * (hi - lo), "{f}: only {min}–{max}");
    }
}

#[test]
fn gen_rods_set_has_its_scale_range_and_no_background() {
    let dir = scratch("rods");
    generate(&dir, &small_opts(Variant::Rods, 2, 2)).expect("generate");
    assert!(!dir.join("background.png").exists() && !dir.join("backgrounds").exists());
    assert_eq!(variant_json(&dir)["background"], json!(false));
    // The set's vorl.toml is read as a config: the scale range the parts need.
    let config = crate::config::Config::load(&dir.join("vorl.toml")).expect("vorl.toml loads");
    assert_eq!((config.scale_min, config.scale_max), (0.8, 1.4));
    assert!(config.to_params().is_ok());
    for parts in truth_of(&dir).frames.values() {
        for p in parts {
            let shape = p.extra["shape"].as_str().expect("shape");
            // Washers and screws are not templates.
            assert_eq!(p.class.is_none(), ["flat_washer", "screw"].contains(&shape), "{shape}");
        }
    }
    assert!(gray(&dir.join("templates").join("rod_a.png")).width() > 100);
    let _ = std::fs::remove_dir_all(dir);
}

/// The `flipped` catalogue's chiral templates are the parts without a mirror axis
/// (`l_bracket`, `shaft_key`, `wrench`, and the `hook` and `l_long` it adds); the others' mirror
/// gap is nothing but sampling. A part of the
/// `flipped` set lying upside down is drawn as its template mirrored left-right about its
/// centroid, then turned by its truth angle (DESIGN.md), keeps its own centroid, and says so in
/// its truth; only chiral parts lie upside down, about half of them.
#[test]
fn gen_flipped_parts_are_mirror_images_and_truth_says_so() {
    let cat = Variant::Flipped.catalogue();
    let gaps: Vec<f64> = cat
        .iter()
        .map(|s| if s.is_template { s.mirror_gap() } else { 0.0 })
        .collect();
    let is_chiral = |i: usize| gaps[i] >= shapes::CHIRAL_GAP;
    let chiral: Vec<&str> = (0..cat.len()).filter(|&i| is_chiral(i)).map(|i| cat[i].name).collect();
    assert_eq!(chiral, ["l_bracket", "shaft_key", "wrench", "hook", "l_long"]);
    for (s, gap) in cat.iter().zip(&gaps).filter(|(s, _)| s.is_template) {
        assert!(*gap < 0.002 || *gap > 0.02, "{}: {gap}", s.name);
        // Mirrored twice: the same rings.
        let back = s.mirrored().mirrored();
        assert!((back.area_mm2() - s.area_mm2()).abs() < 1e-9);
        for (a, b) in back.rings().iter().flatten().zip(s.rings().iter().flatten()) {
            assert!(dist(*a, *b) < 1e-9, "{}", s.name);
        }
    }
    let opts = small_opts(Variant::Flipped, 3, 20);
    let (mut flipped, mut upright) = (0, 0);
    for index in 0..20 {
        let (set, parts, _, _) = clean_frame(&opts, index);
        for p in &parts {
            let t = set.truth(p, index);
            let spec = &set.cat[p.spec];
            assert_eq!(t.flipped, p.flipped.then_some(true));
            if spec.is_template {
                assert_eq!(t.extra["chiral"], json!(is_chiral(p.spec)), "{}", spec.name);
            }
            if !is_chiral(p.spec) {
                assert!(!p.flipped, "{}", spec.name);
                continue;
            }
            let drawn = p.drawn(&set.cat);
            // The drawn shape is the template's mirror image, point by point.
            for k in 0..400 {
                let q = [(k % 20) as f64 * 6.0 - 57.0, (k / 20) as f64 * 6.0 - 57.0];
                let want = if p.flipped {
                    spec.coverage(-q[0], q[1])
                } else {
                    spec.coverage(q[0], q[1])
                };
                assert_eq!(drawn.coverage(q[0], q[1]), want, "{} at {q:?}", spec.name);
            }
            let (_, c) = silhouette(drawn, &p.pose, set.w, set.h).moments();
            assert!(dist(c, [t.x, t.y]) < 0.02, "{}", spec.name);
            if p.flipped {
                flipped += 1;
            } else {
                upright += 1;
            }
        }
    }
    assert!(flipped >= 2 && upright >= 2, "{flipped} flipped, {upright} upright");
}

/// `touching`: moved parts share pixels with their partner (they form one blob) by no more
/// than the drawn share of the smaller part's area; truth marks both and the lower one's
/// visible share; the part on top hides the one beneath (inside it the frame is what the top
/// part alone would give); parts that touch nothing keep their distance.
#[test]
fn gen_touching_parts_share_pixels_and_the_upper_hides_the_lower() {
    let opts = small_opts(Variant::Touching, 5, 20);
    let (mut pairs, mut deep_pixels) = (0, 0);
    for index in 0..20 {
        let set = SetPlan::new(&opts);
        let mut rng = Rng::stream(opts.seed, purpose::LAYOUT, index as u64);
        let mut parts = plan(&mut rng, &set.cat, &set.scene);
        let mut fx = Rng::stream(opts.seed, purpose::EFFECT_SCENE, index as u64);
        touching::bring_together(&mut fx, &set.cat, &mut parts, set.w, set.h);
        let cover = |p: &Placed| silhouette(p.drawn(&set.cat), &p.pose, set.w, set.h);
        for (i, p) in parts.iter().enumerate() {
            let t = set.truth(p, index);
            assert_eq!(t.touching, p.touching.then_some(true));
            for (j, q) in parts.iter().enumerate().skip(i + 1) {
                let (cp, cq) = (cover(p), cover(q));
                let (mut shared, mut ap, mut aq) = (0.0, 0.0, 0.0);
                cp.for_each(|x, y, c| {
                    ap += c;
                    shared += c.min(cq.at(x, y));
                });
                cq.for_each(|_, _, c| aq += c);
                if p.touching && q.touching && shared > 0.0 {
                    pairs += 1;
                    assert!(
                        shared / f64::min(ap, aq) <= touching::OVERLAP_MAX + 0.01,
                        "{index}: {i}-{j}"
                    );
                    // The lower one (drawn first) shows what the upper one leaves.
                    assert!(
                        (p.visible - (1.0 - shared / ap)).abs() < 0.02,
                        "{} {}",
                        p.visible,
                        shared / ap
                    );
                    assert_eq!(t.extra["visible_fraction"], json!(p.visible));
                    // Inside the upper part the frame is the upper part alone.
                    let alone = set.compose(&parts[j..=j], false, &mut Rng::stream(1, 1, 1));
                    let both = set.compose(&parts, false, &mut Rng::stream(1, 1, 1));
                    let mut inside = 0;
                    cq.for_each(|x, y, c| {
                        let k = y as usize * set.w + x as usize;
                        // Where both cover the pixel, 5 px inside the upper part's edge (past the blur).
                        let deep = [(5, 0), (-5, 0), (0, 5), (0, -5), (4, 4), (-4, 4), (4, -4), (-4, -4)]
                            .iter()
                            .all(|(dx, dy)| cq.at(x + dx, y + dy) == 1.0);
                        if c == 1.0 && cp.at(x, y) == 1.0 && deep {
                            inside += 1;
                            assert!((alone[k] - both[k]).abs() < 1e-6, "{index}: ({x}, {y})");
                        }
                    });
                    deep_pixels += inside;
                } else if !p.touching || !q.touching {
                    assert_eq!(shared, 0.0, "{index}: {i}-{j} share pixels but are not touching");
                }
            }
        }
    }
    assert!(pairs >= 6, "{pairs} touching pairs in 20 frames");
    assert!(
        deep_pixels > 100,
        "{deep_pixels} pixels of overlap deep inside an upper part"
    );
}

/// Whether a part (`on`: whether it covers an image pixel) lies between image point `q` and the
/// light, within 25 px of `q` towards it (`toward`: the unit vector to the light): `q` is on the
/// part's far side.
fn casts_on(on: impl Fn(i64, i64) -> bool, toward: P, q: P) -> bool {
    (1..=25).any(|s| {
        let s = f64::from(s);
        on(
            (q[0] + s * toward[0]).round() as i64,
            (q[1] + s * toward[1]).round() as i64,
        )
    })
}

/// The outer borders of `spec` (its rings of positive area: holes left out).
fn outer_rings(spec: &PartSpec) -> Vec<Vec<P>> {
    spec.rings()
        .iter()
        .filter(|r| shapes::ring_moments(r).0 > 0.0)
        .cloned()
        .collect()
}

/// Whether image point `q` lies inside the outer border (holes filled) of `spec` at `pose`.
fn within_outer(spec: &PartSpec, pose: &raster::Pose, q: P) -> bool {
    let m = pose.invert(q);
    outer_rings(spec)
        .iter()
        .any(|r| shapes::inside(std::slice::from_ref(r), m[0], m[1]))
}

/// The pixels of a `w`×`h` image whose centres lie within `margin` px (a square) of a part's
/// outer border (`parts`: shape and pose; holes filled), row-major.
fn near_parts(parts: &[(&PartSpec, raster::Pose)], w: usize, h: usize, margin: i64) -> Vec<bool> {
    let mut near = vec![false; w * h];
    for (spec, pose) in parts {
        raster::coverage(&pose.rings(&outer_rings(spec)), Some((w, h)), 4).for_each(|x, y, _| {
            for yy in (y - margin).max(0)..=(y + margin).min(h as i64 - 1) {
                for xx in (x - margin).max(0)..=(x + margin).min(w as i64 - 1) {
                    near[yy as usize * w + xx as usize] = true;
                }
            }
        });
    }
    near
}

/// `frontlit` on clean frames (no noise, no drift): each part is brighter than the lit mat on
/// average and its dark facet covers the share truth states; truth is the silhouette's own
/// centroid; the mat away from the parts is the mat or darker (never by more than a shadow's
/// depth), and the darkening about each part lies on its far side from the light, where
/// truth's shadow offset points.
#[test]
fn gen_frontlit_parts_are_bright_metal_and_shadows_fall_away_from_the_light() {
    let opts = GenOptions {
        seed: 5,
        frames: 8,
        variant: Variant::Frontlit,
        ..GenOptions::default()
    };
    let (mut checked, mut edges, mut bands) = (0, 0, 0);
    for index in 0..8 {
        let (set, parts, img, light) = clean_frame(&opts, index);
        let Effect::Frontlit(f) = &set.effect else {
            panic!("frontlit variant without its light");
        };
        let (w, h) = (set.w, set.h);
        let toward = f.toward();
        let mut lit = f.field.clone();
        blur(&mut lit, w, h, BLUR_SIGMA);
        let covers: Vec<raster::Coverage> = parts
            .iter()
            .map(|p| silhouette(p.drawn(&set.cat), &p.pose, w, h))
            .collect();
        // Within 3 px of a part (the optical blur's reach).
        let mut near = vec![false; w * h];
        for cov in &covers {
            cov.for_each(|x, y, _| {
                for dy in -3..=3_i64 {
                    for dx in -3..=3_i64 {
                        let (xx, yy) = (x + dx, y + dy);
                        if xx >= 0 && yy >= 0 && (xx as usize) < w && (yy as usize) < h {
                            near[yy as usize * w + xx as usize] = true;
                        }
                    }
                }
            });
        }
        let shapes: Vec<(&PartSpec, raster::Pose)> = parts.iter().map(|p| (p.drawn(&set.cat), p.pose)).collect();
        let holes = near_parts(&shapes, w, h, 0);
        // Away from the parts: the mat, or darker by at most a shadow's depth.
        let mut dark = vec![0.0; w * h];
        for i in (0..w * h).filter(|&i| !near[i]) {
            let d = light[i] - img[i];
            assert!(
                d > -1e-9 && d <= SHADOW_DEPTH_MAX + 1e-9,
                "{index}: pixel {i} darkened by {d}"
            );
            dark[i] = d;
        }
        for (k, (p, cov)) in parts.iter().zip(&covers).enumerate() {
            let t = set.truth(p, index);
            let spec = p.drawn(&set.cat);
            let c = [t.x, t.y];
            assert!(dist(cov.moments().1, c) < 0.02, "{}", spec.name);
            assert_eq!(t.extra["texture"], json!("metal"));
            let Texture::Metal(metal) = &p.look.texture else {
                panic!("a frontlit part that is not metal");
            };
            // The facet covers the share of the part truth states.
            let (mut area, mut on_facet) = (0.0, 0.0);
            cov.for_each(|x, y, a| {
                area += a;
                if metal.in_facet(p.pose.invert([x as f64, y as f64])) {
                    on_facet += a;
                }
            });
            let want = t.extra["facet_share"].as_f64().expect("facet_share");
            assert!((0.04..0.16).contains(&want), "{want}");
            assert!(
                (on_facet / area - want).abs() < 0.02,
                "{}: {} vs {want}",
                spec.name,
                on_facet / area
            );
            // The pixels 2 px or more inside the part: brighter than the lit mat on average;
            // those near the mat's level (metal is 40 or more above it, an edge facet 5 or
            // less) are those of an edge facet; a band facet lies at 40–70 % of the contrast
            // (at least 16 levels above the mat), never near it.
            let (mut sum, mut n, mut low, mut facet) = (0.0, 0usize, 0usize, 0usize);
            cov.for_each(|x, y, _| {
                if (-2..=2).all(|dy: i64| (-2..=2).all(|dx: i64| cov.at(x + dx, y + dy) == 1.0)) {
                    let v = img[y as usize * w + x as usize] - lit[y as usize * w + x as usize];
                    sum += v;
                    n += 1;
                    low += usize::from(v < 22.5);
                    facet += usize::from(metal.in_facet(p.pose.invert([x as f64, y as f64])));
                }
            });
            assert!(n > 100, "{}: {n} deep pixels", spec.name);
            let mean = sum / n as f64;
            assert!((30.0..150.0).contains(&mean), "{}: {mean} above the mat", spec.name);
            assert!(facet > 0, "{}: no facet inside", spec.name);
            let (low, facet) = (low as f64 / n as f64, facet as f64 / n as f64);
            let edge = t.extra["facet"].as_str() == Some("edge");
            let near_mat = if edge { facet } else { 0.0 };
            assert!(
                (low - near_mat).abs() < 0.02,
                "{}: {low} near the mat, facet {facet} ({})",
                spec.name,
                t.extra["facet"]
            );
            match t.extra["facet"].as_str() {
                Some("edge") => edges += 1,
                Some("band") => bands += 1,
                other => panic!("facet {other:?}"),
            }
            // The shadow's offset: away from the light, 4–10 px.
            let off = [
                t.extra["shadow_dx"].as_f64().expect("dx"),
                t.extra["shadow_dy"].as_f64().expect("dy"),
            ];
            let len = off[0].hypot(off[1]);
            assert!((4.0..10.0).contains(&len), "{len}");
            assert!(((off[0] * toward[0] + off[1] * toward[1]) + len).abs() < 1e-9);
            // The mat's darkening about this part (the pixels nearer its bounding circle than any
            // other's), outside its outer border.
            let r = spec.radius_mm() * p.pose.k;
            let gap = |q: P, j: usize| {
                let o = &parts[j];
                dist(q, [o.pose.cx, o.pose.cy]) - o.drawn(&set.cat).radius_mm() * o.pose.k
            };
            let (mut far, mut lit_side, mut s, mut sx, mut sy, mut peak) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0_f64);
            for y in (c[1] - r - 25.0).max(0.0) as usize..((c[1] + r + 25.0) as usize + 1).min(h) {
                for x in (c[0] - r - 25.0).max(0.0) as usize..((c[0] + r + 25.0) as usize + 1).min(w) {
                    let (i, q) = (y * w + x, [x as f64, y as f64]);
                    if near[i] || holes[i] || (0..parts.len()).any(|j| j != k && gap(q, j) < gap(q, k)) {
                        continue;
                    }
                    let d = dark[i];
                    if d <= 0.0 {
                        continue;
                    }
                    let v = [q[0] - c[0], q[1] - c[1]];
                    if casts_on(|x, y| cov.at(x, y) > 0.5, toward, q) {
                        far += d;
                    } else {
                        lit_side += d;
                    }
                    s += d;
                    sx += d * v[0];
                    sy += d * v[1];
                    peak = peak.max(d);
                }
            }
            assert!(far > 3.0 * lit_side, "{}: far {far}, lit side {lit_side}", spec.name);
            let m = [sx / s, sy / s];
            let along = (m[0] * off[0] + m[1] * off[1]) / (m[0].hypot(m[1]) * len);
            assert!(along > 0.5, "{}: shadow at {m:?}, offset {off:?}", spec.name);
            let depth = t.extra["shadow_depth"].as_f64().expect("depth");
            assert!(
                peak > 0.15 * depth && peak <= depth + 1e-9,
                "{}: {peak} of {depth}",
                spec.name
            );
            checked += 1;
        }
    }
    assert!(checked >= 15 && edges >= 3 && bands >= 1, "{checked} {edges} {bands}");
}

/// The most a `frontlit` shadow darkens the mat.
const SHADOW_DEPTH_MAX: f64 = frontlit::SHADOW_DEPTH.1;

/// A `frontlit` set as written: `background.png` is the textured mat without shadows; in every
/// frame the mat darker than the background lies on the parts' far side from the light (the
/// direction `variant.json` states); `teach.json` names, for each class, the first frame where
/// a part of it lies whole and that part's centroid: inside its outer border, on a part brighter
/// than the background, and no class that lies whole somewhere is left out.
#[test]
fn gen_frontlit_set_has_its_mat_shadows_and_teach_points() {
    let dir = scratch("frontlit");
    let opts = GenOptions {
        seed: 4,
        frames: 10,
        variant: Variant::Frontlit,
        ..GenOptions::default()
    };
    let summary = generate(&dir, &opts).expect("generate");
    let bg = gray(&dir.join("background.png"));
    let (w, h) = (bg.width() as usize, bg.height() as usize);
    let mean = bg.pixels().map(|p| f64::from(p.0[0])).sum::<f64>() / (w * h) as f64;
    assert!((100.0..=130.0).contains(&mean), "mat at {mean}");
    // σ = 2 sensor noise alone gives fine detail of about 2 levels; the mat's texture more.
    let fine = effects::spread(&detail(&bg)).1;
    assert!(fine > 3.0, "texture: {fine}");
    let toward = variant_json(&dir)["light_toward"].clone();
    let toward = [
        toward[0].as_f64().expect("toward x"),
        toward[1].as_f64().expect("toward y"),
    ];
    let cat = catalogue();
    let spec_of = |p: &PartJson| {
        let shape = p.extra["shape"].as_str().expect("shape");
        cat.iter().find(|s| s.name == shape).expect("shape in catalogue")
    };
    let pose_of = |p: &PartJson| raster::Pose::new(p.x, p.y, p.angle_deg, p.extra["scale"].as_f64().expect("scale"));
    let truth = truth_of(&dir);
    let (mut far, mut lit_side) = (0usize, 0usize);
    for (name, parts) in &truth.frames {
        let frame = gray(&dir.join("frames").join(name));
        // The parts with 3 px around them (their outer borders, holes filled).
        let shapes: Vec<(&PartSpec, raster::Pose)> = parts.iter().map(|p| (spec_of(p), pose_of(p))).collect();
        let near = near_parts(&shapes, w, h, 3);
        let covers: Vec<raster::Coverage> = shapes.iter().map(|(spec, pose)| silhouette(spec, pose, w, h)).collect();
        for (i, (f, b)) in frame.pixels().zip(bg.pixels()).enumerate() {
            if near[i] || f64::from(f.0[0]) > f64::from(b.0[0]) - 20.0 {
                continue;
            }
            // A shadow pixel: is a part between it and the light?
            let q = [(i % w) as f64, (i / w) as f64];
            if casts_on(|x, y| covers.iter().any(|c| c.at(x, y) > 0.5), toward, q) {
                far += 1;
            } else {
                lit_side += 1;
            }
        }
    }
    assert!(far > 500 && far > 20 * lit_side, "far {far}, lit side {lit_side}");
    // teach.json.
    let teach: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("teach.json")).expect("teach.json")).expect("json");
    let teach = teach.as_object().expect("an object");
    let mut moved = 0;
    assert!(teach.keys().all(|k| summary.classes.contains(k)), "{teach:?}");
    for class in &summary.classes {
        let whole =
            |p: &&PartJson| p.class.as_deref() == Some(class.as_str()) && p.partial.is_none() && p.touching.is_none();
        let first = truth
            .frames
            .iter()
            .find_map(|(name, parts)| parts.iter().find(whole).map(|p| (name, p)));
        let Some(entry) = teach.get(class) else {
            assert!(
                first.is_none(),
                "{class} lies whole in {first:?} but is not in teach.json"
            );
            continue;
        };
        let (name, p) = first.expect("a class in teach.json lies whole somewhere");
        let file = entry["frame"].as_str().expect("frame");
        assert_eq!(file, format!("frames/{name}"), "{class}");
        assert!(dir.join(file).is_file(), "{file}");
        let at = [entry["x"].as_f64().expect("x"), entry["y"].as_f64().expect("y")];
        let (spec, pose) = (spec_of(p), pose_of(p));
        // The centroid, or where that lies off the part (an L bracket's), a point of the part
        // 3 px or more inside it, near the centroid.
        if within_outer(spec, &pose, [p.x, p.y]) {
            assert!(dist(at, [p.x, p.y]) < 1e-9, "{class}: {at:?} vs {} {}", p.x, p.y);
        } else {
            moved += 1;
            assert!(
                dist(at, [p.x, p.y]) < spec.radius_mm() * pose.k / 2.0,
                "{class}: {at:?}"
            );
            let m = pose.invert(at);
            assert!(
                scene::clearance(spec.rings(), m) * pose.k >= 2.99 && spec.coverage(m[0], m[1]),
                "{class}"
            );
        }
        assert_eq!(spec.name, class.as_str());
        // Whole: inside the frame.
        let b = raster::bounds(&pose.rings(spec.rings()));
        assert!(
            b[0] > 0.0 && b[1] > 0.0 && b[2] < w as f64 - 1.0 && b[3] < h as f64 - 1.0,
            "{class}: {b:?}"
        );
        assert!(within_outer(spec, &pose, at), "{class}: {at:?} outside the part");
        // The part is there, brighter than the mat: its pixels 3 px inside it.
        let frame = gray(&dir.join(file));
        let r = spec.radius_mm() * pose.k;
        let (mut sum, mut n) = (0.0, 0.0);
        for y in (at[1] - r) as u32..(at[1] + r) as u32 + 1 {
            for x in (at[0] - r) as u32..(at[0] + r) as u32 + 1 {
                let deep = [(0.0, 0.0), (3.0, 0.0), (-3.0, 0.0), (0.0, 3.0), (0.0, -3.0)]
                    .iter()
                    .all(|&(dx, dy)| {
                        let m = pose.invert([f64::from(x) + dx, f64::from(y) + dy]);
                        spec.coverage(m[0], m[1])
                    });
                if deep {
                    sum += f64::from(frame.get_pixel(x, y).0[0]) - f64::from(bg.get_pixel(x, y).0[0]);
                    n += 1.0;
                }
            }
        }
        assert!(
            n > 100.0 && sum / n > 30.0,
            "{class}: {} above the mat over {n} px",
            sum / n
        );
    }
    assert!(
        teach.len() >= 8 && moved >= 1,
        "{} classes taught, {moved} off the centroid",
        teach.len()
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn gen_large_parts_cover_a_quarter_to_half_of_the_frame_on_printed_paper() {
    // The catalogue's large parts cover their share of the reference frame.
    let cat = large_catalogue();
    let reference = LARGE_REFERENCE_PX.0 * LARGE_REFERENCE_PX.1;
    for (name, share) in LARGE_SHARES {
        let spec = cat.iter().find(|p| p.name == name).expect("a large part");
        assert!((spec.area_mm2() / reference - share).abs() < 1e-9, "{name}");
        assert!((0.25..=0.5).contains(&share), "{name}");
    }
    let opts = GenOptions {
        seed: 6,
        frames: 12,
        variant: Variant::Large,
        width: 320,
        height: 240,
        background: None,
    };
    let (mut dark, mut bright, mut small) = (0, 0, 0);
    for index in 0..opts.frames {
        let (set, parts, img, light) = clean_frame(&opts, index);
        let Effect::Large(paper) = &set.effect else {
            panic!("large variant without its paper");
        };
        let frame = (set.w * set.h) as f64;
        // One large part, its template at the frame's scale.
        let shares: Vec<f64> = parts
            .iter()
            .map(|p| set.cat[p.spec].area_mm2() * p.pose.k * p.pose.k / frame)
            .collect();
        let large: Vec<usize> = (0..parts.len()).filter(|&i| shares[i] >= 0.2).collect();
        assert_eq!(large.len(), 1, "frame {index}: {shares:?}");
        assert!((0.24..=0.52).contains(&shares[large[0]]), "{shares:?}");
        small += parts.len() - 1;
        for (i, p) in parts.iter().enumerate() {
            let t = set.truth(p, index);
            assert!((t.extra["scale"].as_f64().expect("scale") - 1.0).abs() <= 0.03);
            let Body::Opaque { level } = p.body else {
                panic!("a large-set part that is not opaque");
            };
            assert_eq!(t.extra["level"], json!(level));
            if level < 128.0 {
                dark += 1;
            } else {
                bright += 1;
            }
            // Opaque: the print is hidden, the part's pixels 3 px inside it (beyond the blur) are
            // its level.
            let spec = &set.cat[p.spec];
            let cov = silhouette(spec, &p.pose, set.w, set.h);
            let mut deep = 0;
            cov.for_each(|x, y, _| {
                if (-3..=3).all(|dy: i64| (-3..=3).all(|dx: i64| cov.at(x + dx, y + dy) == 1.0)) {
                    deep += 1;
                    assert!((img[y as usize * set.w + x as usize] - level).abs() < 1e-6);
                }
            });
            assert!(i != large[0] || deep > 1000, "{}: {deep}", spec.name);
        }
        // The paper: white, printed (a share of dark ink), the print part of the platform.
        assert!((large::PAPER_LEVEL.0..large::PAPER_LEVEL.1).contains(&paper.level));
        assert!(paper.ink_share > 0.05 && paper.ink_share < 0.5, "{}", paper.ink_share);
        let inked = light.iter().filter(|&&v| v < paper.level - 40.0).count() as f64 / frame;
        assert!(inked > 0.03, "{inked}");
    }
    assert!(
        dark >= 2 && bright >= 2 && small >= 2,
        "{dark} dark, {bright} bright, {small} small"
    );
    // background.png is the printed paper.
    let dir = scratch("large");
    generate(&dir, &small_opts(Variant::Large, 6, 1)).expect("generate");
    let bg = gray(&dir.join("background.png"));
    let level = variant_json(&dir)["paper_level"].as_f64().expect("paper_level");
    let inked = bg.pixels().filter(|p| f64::from(p.0[0]) < level - 40.0).count();
    assert!(inked as f64 > 0.03 * f64::from(bg.width() * bg.height()), "{inked}");
    let _ = std::fs::remove_dir_all(dir);
}
