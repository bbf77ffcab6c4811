//! The partial search's junction gate (`vorl_core::recognizer::split`, "Blobs of one part")
//! against the search it spares, on generated frames: every frame of a `touching` set (parts
//! against and over one another, about 60 % of them), of a `rods-touching` set and of a
//! `default` set (its unknown parts: stars, crescents, smooth blobs) gives the same parts, the
//! partial search on, with the gate on (as the recognizer starts) and off. The test fails if the gate ever drops or changes a part
//! the full search finds.

use std::path::Path;

use vorl_host_sim::config::Config;
use vorl_host_sim::engine::{Engine, HostDetection};
use vorl_host_sim::gen::{generate, GenOptions, Variant};
use vorl_host_sim::io::load_gray;
use vorl_host_sim::set::FixtureSet;

mod common;
use common::Scratch;

/// An engine for the set at `root` as `vorl detect --touching-parts true` makes it (its
/// `vorl.toml` over the defaults, the partial search on, its templates, its empty shot), with
/// the gate on or off.
fn engine(root: &Path, gate: bool) -> Engine {
    let set = FixtureSet::open(root).unwrap();
    let mut config = match set.config().unwrap() {
        Some(path) => Config::default().overlay(&path).unwrap(),
        None => Config::default(),
    };
    config.touching_parts = true;
    let mut engine = Engine::new(config.to_params().unwrap()).unwrap();
    engine.set_junction_gate(gate);
    engine.learn_background(&set.load_backgrounds().unwrap()).unwrap();
    engine.add_silhouettes(&set.load_templates().unwrap()).unwrap();
    engine
}

/// What a detection says, bit for bit (all but the DP searches it took).
fn key(d: &HostDetection) -> String {
    let c = &d.core;
    format!(
        "{:?} {:?} {} {} {} {} {} {} {}",
        d.class,
        d.best_class,
        c.x.to_bits(),
        c.y.to_bits(),
        c.angle_deg.to_bits(),
        c.touching,
        c.visible_fraction.to_bits(),
        c.touches_edge,
        c.position_from_pose
    )
}

/// Generates a set and holds every frame's parts with the gate on against those with it off;
/// returns the parts found along a blob (`touching`) and all parts.
fn gate_keeps_every_part(variant: Variant, seed: u64, frames: usize) -> (usize, usize) {
    let scratch = Scratch::new("junction-gate");
    let root = scratch.join("set");
    generate(
        &root,
        &GenOptions {
            seed,
            frames,
            variant,
            // The empty shot, also for the backlit rods (written on request).
            background: Some(true),
            ..GenOptions::default()
        },
    )
    .unwrap();
    let (mut on, mut off) = (engine(&root, true), engine(&root, false));
    let mut names: Vec<_> = std::fs::read_dir(root.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    let (mut touching, mut parts) = (0usize, 0usize);
    for path in &names {
        let frame = load_gray(path).unwrap().image;
        let with = on.detect(&frame).unwrap();
        let without = off.detect(&frame).unwrap();
        let (a, b): (Vec<String>, Vec<String>) = (
            with.detections.iter().map(key).collect(),
            without.detections.iter().map(key).collect(),
        );
        assert_eq!(
            a,
            b,
            "{variant:?} seed {seed}, {}: gate on (left) and off",
            path.display()
        );
        touching += with.detections.iter().filter(|d| d.core.touching).count();
        parts += with.detections.len();
    }
    (touching, parts)
}

#[test]
fn the_junction_gate_keeps_every_touching_part() {
    let (touching, parts) = gate_keeps_every_part(Variant::Touching, 7, 12);
    assert!(touching >= 10 && parts >= 30, "{touching} touching of {parts}");
}

#[test]
fn the_junction_gate_keeps_every_touching_rod() {
    let (touching, parts) = gate_keeps_every_part(Variant::RodsTouching, 7, 8);
    assert!(touching >= 6 && parts >= 20, "{touching} touching of {parts}");
}

#[test]
fn the_junction_gate_changes_no_part_of_a_default_set() {
    let (_, parts) = gate_keeps_every_part(Variant::Default, 7, 12);
    assert!(parts >= 30, "{parts}");
}
