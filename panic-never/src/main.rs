//! # vorl-panic-never
//!
//! A link-time proof that `vorl-core` holds no panic path: this program calls every public entry
//! point of the core with inputs the optimiser cannot see (each value is a volatile read, each
//! buffer's contents and length pass through [`black_box`]), and its `#[panic_handler]` calls
//! `vorl_core_can_panic`, a symbol that nothing defines. If any panic path of the core (a bounds
//! check, a division by zero, a failed `copy_from_slice`, an `unwrap`, an overflow check, a
//! `clamp` with crossed bounds) survives optimisation, the handler is reached from live code and
//! the link fails with `undefined symbol: vorl_core_can_panic`; if none does, the handler is
//! dead code and the program links.
//!
//! It is built like the firmware (`thumbv7em-none-eabihf`, `opt-level = 3`, fat LTO, one codegen
//! unit) and never run:
//!
//! ```sh
//! cd panic-never && cargo build --release
//! ```
//!
//! Left out, and why: `Debug` and `Display` (formatting is `core::fmt`'s code, whose float
//! formatting holds bounds checks of its own) and the accessors that only return a field. Every
//! call here must itself be free of panics, so the program uses `get` and iterators, never `[i]`.

#![no_std]
#![no_main]

use core::hint::black_box;
use core::ptr::{addr_of, addr_of_mut, read_volatile};

use vorl_core::borders::contour::{self, BorderFilter, ContourStore, Point};
use vorl_core::borders::resample;
use vorl_core::library::template::Template;
use vorl_core::library::{self, Library};
use vorl_core::location::calibrate::{Homography, RigidTransform};
use vorl_core::location::stereo::{self, DisparityParams, PairOutcome, PairParams, StereoPart, StereoRig};
use vorl_core::params::{AngleEstimator, Params, Position, Refine};
use vorl_core::pixels::background::Background;
use vorl_core::pixels::enhance::{self, Alpha};
use vorl_core::pixels::frame::{Frame, FrameBuffer};
use vorl_core::pixels::mask::{self, Cleanup, Polarity, RowSpans, Threshold};
use vorl_core::pose;
use vorl_core::pose::holes;
use vorl_core::pose::partial_volume::{partial_volume_centroid, partial_volume_moments, print_deficit, Rect};
use vorl_core::pose::refine::{self, Difference, Outline, Pose, ProfileRay, RefineParams};
use vorl_core::recognizer::{Recognizer, Stage};
use vorl_core::shape::descriptor::{self, DescriptorParams};
use vorl_core::shape::matching;

#[cfg(not(feature = "diagnose"))]
extern "Rust" {
    /// Defined nowhere: referring to it from live code fails the link.
    fn vorl_core_can_panic() -> !;
}

#[cfg(not(feature = "diagnose"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    // SAFETY: never called in a program that links (the symbol does not exist).
    unsafe { vorl_core_can_panic() }
}

/// `--features diagnose`: a handler that exists, so the program links and its disassembly shows
/// where the panic paths are (`scripts/panic-sites.sh`).
#[cfg(feature = "diagnose")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {}
}

// ---------------------------------------------------------------------------------------------
// Opaque inputs.

/// The source of every scalar: a volatile read, so the optimiser knows nothing of the value.
static mut SOURCE: u64 = 0;

fn word() -> u64 {
    // SAFETY: a plain read of a `u64` static; the program is single-threaded and never run.
    unsafe { read_volatile(addr_of!(SOURCE)) }
}

fn u() -> usize {
    word() as usize
}

fn u8_() -> u8 {
    word() as u8
}

fn u16_() -> u16 {
    word() as u16
}

fn i32_() -> i32 {
    word() as i32
}

fn isize_() -> isize {
    word() as isize
}

/// Any `f32`: NaN, ±∞, 0, subnormal, huge.
fn f() -> f32 {
    f32::from_bits(word() as u32)
}

fn p2() -> [f32; 2] {
    [f(), f()]
}

fn p3() -> [f32; 3] {
    [f(), f(), f()]
}

fn flag() -> bool {
    word() & 1 == 1
}

/// A buffer of a static's storage with contents and length unknown to the optimiser (the
/// pointer escapes through `black_box`, so anything may have been written there).
macro_rules! buffer {
    ($ty:ty, $n:expr, $init:expr) => {{
        static mut BUF: [$ty; $n] = [$init; $n];
        // SAFETY: each expansion has its own static, borrowed once per call of `_start`'s body.
        let all: &'static mut [$ty] = black_box(unsafe { &mut *addr_of_mut!(BUF) });
        let len = u().min(all.len());
        black_box(all.get_mut(..len).unwrap_or_default())
    }};
}

fn threshold() -> Threshold {
    if flag() {
        Threshold::Otsu
    } else {
        Threshold::Fixed(u8_())
    }
}

fn cleanup() -> Cleanup {
    match u8_() % 3 {
        0 => Cleanup::Off,
        1 => Cleanup::Open,
        _ => Cleanup::OpenClose,
    }
}

fn polarity() -> Polarity {
    match u8_() % 3 {
        0 => Polarity::Either,
        1 => Polarity::Darker,
        _ => Polarity::Brighter,
    }
}

fn params() -> Params {
    Params {
        alpha: f(),
        threshold: threshold(),
        polarity: polarity(),
        cleanup: cleanup(),
        min_points: u(),
        min_area: f(),
        n: u(),
        m: u(),
        k: u(),
        omega: f(),
        epsilon: f(),
        angle: if flag() {
            AngleEstimator::Paper
        } else {
            AngleEstimator::Signed
        },
        refine: match u8_() % 3 {
            0 => Refine::Off,
            1 => Refine::Pose,
            _ => Refine::Verify,
        },
        candidates: u(),
        candidate_ratio: f(),
        verify_threshold: f(),
        verify_relative: f(),
        offset_relative: f(),
        scale_min: f(),
        scale_max: f(),
        position: if flag() {
            Position::Polygon
        } else {
            Position::PartialVolume
        },
        nested_parts: flag(),
        flipped_parts: flag(),
        touching_parts: flag(),
    }
}

fn refine_params() -> RefineParams {
    RefineParams {
        iterations: u(),
        search: f(),
        step: f(),
        min_contrast: f(),
        cap: f(),
        give_up: f(),
        offset_max: f(),
        wall_max: f(),
        wall_toward: p2(),
    }
}

fn disparity_params() -> DisparityParams {
    DisparityParams {
        search_px: f(),
        step_px: f(),
        min_contrast: f(),
        window_px: f(),
        iterations: u(),
        normal_span: u(),
        min_normal_x: f(),
        max_residual_px: f(),
        min_points: u(),
        max_shift_px: f(),
        tolerance_px: f(),
    }
}

fn pose_() -> Pose {
    Pose {
        x: f(),
        y: f(),
        angle: f(),
        scale: f(),
    }
}

fn rect() -> Rect {
    Rect {
        x0: u(),
        y0: u(),
        x1: u(),
        y1: u(),
    }
}

fn alpha() -> Alpha {
    Alpha::new(f()).unwrap_or(Alpha::ONE)
}

/// A frame of any size over any bytes (`None` when the core refuses it).
fn frame(data: &[u8]) -> Option<Frame<&[u8]>> {
    if flag() {
        Frame::new_checked(data, u(), u()).ok()
    } else {
        Frame::with_stride(data, u(), u(), u()).ok()
    }
}

fn points() -> &'static mut [Point] {
    buffer!(Point, 512, Point { x: 0, y: 0 })
}

fn floats() -> &'static mut [f32] {
    buffer!(f32, 512, 0.0)
}

fn pairs2() -> &'static mut [[f32; 2]] {
    buffer!([f32; 2], 512, [0.0; 2])
}

// ---------------------------------------------------------------------------------------------
// The entry points.

/// The firmware's configuration (firmware-example: `Recognizer<8, 96, 4096, 64, 2112>`).
type Firmware = Recognizer<8, 96, 4096, 64, 2112>;
/// A second, tiny configuration: the capacities' edge cases.
type Tiny = Recognizer<1, 8, 16, 1, 1>;

fn recognizer<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize>(
    rec: &mut Recognizer<T, M, P, C, D>,
) {
    let _ = black_box(rec.set_params(params()));
    let frame_data = buffer!(u8, 4096, 0);
    let bg_plane = buffer!(u8, 4096, 0);
    let labels = buffer!(u8, 4096, 0);
    let high = buffer!(u8, 4096, 0);
    if let Some(fr) = frame(frame_data) {
        let _ = black_box(rec.teach(&fr, labels));
        if let Ok(t) = Template::<M>::from_silhouette(&fr, &params(), labels, &mut ContourStore::<P, C>::new()) {
            let _ = black_box(rec.add_template(t));
        }
        if let Ok(mut bg) = Background::new(bg_plane, u(), u()) {
            let _ = black_box(bg.learn(&fr, alpha(), high));
            let _ = black_box(bg.finish_learning(high));
            if flag() {
                let _ = black_box(bg.set_from_frame(&fr, alpha()));
            }
            let _ = black_box(bg.update(&fr, alpha(), labels, u8_()));
            if flag() {
                // No empty shot: the platform estimated from the frame.
                let mut grid = vorl_core::pixels::platform::PlatformGrid::<64>::new();
                let _ = black_box(bg.estimate_from_frame(&fr, alpha(), &mut grid));
                // And kept for the next frames while they fit it.
                let mut keeping = vorl_core::pixels::background::PlatformKeeping::new(u() as u32);
                if let Ok(used) = black_box(bg.estimate_or_keep(&fr, alpha(), &mut grid, &mut keeping)) {
                    black_box(used.stats());
                }
                keeping.reset();
            }
            if flag() {
                let _ = black_box(rec.process(&fr, &bg, labels));
            } else {
                let _ = black_box(rec.process_observed(&fr, &bg, labels, |s: Stage| {
                    black_box(s);
                }));
            }
        }
    }
    let store = rec.contours();
    let i = u();
    black_box(store.points(i));
    black_box(store.largest_outer());
    for h in store.holes_of(i) {
        black_box(h);
    }
    black_box(store.contours().iter().map(|c| c.area()).sum::<f32>());
    black_box(rec.templates().len());
    if flag() {
        rec.clear_templates();
    }
}

fn library_entry<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize>(
    rec: &mut Recognizer<T, M, P, C, D>,
) {
    let bytes = buffer!(u8, 8192, 0);
    black_box(library::crc32(bytes));
    black_box(library::record_len(u()));
    black_box(library::encoded_len(u(), u()));
    if let Ok(lib) = Library::parse(bytes) {
        black_box((lib.n(), lib.m(), lib.k(), lib.omega(), lib.len(), lib.checksum()));
        black_box(lib.params(params()));
        black_box(lib.name(u()));
        let _ = black_box(lib.template::<M>(u()));
        let _ = black_box(rec.load_library(&lib));
    }
    let out = buffer!(u8, 8192, 0);
    let name = core::str::from_utf8(buffer!(u8, 64, 0)).unwrap_or("");
    if let Some(t) = rec.templates().first() {
        let _ = black_box(library::write_library(out, &params(), [(name, t), (name, t)]));
    }
}

fn pixels() {
    let data = buffer!(u8, 4096, 0);
    if let Some(fr) = frame(data) {
        black_box(fr.get(u(), u()));
        black_box(fr.get_clamped(isize_(), isize_()));
        black_box(fr.row(u()));
        black_box(fr.pixels());
        let other = buffer!(u8, 4096, 0);
        if let Some(o) = frame(other) {
            let _ = black_box(fr.check_same_size(&o));
        }
        let out = buffer!(u8, 4096, 0);
        enhance::enhance_row(&fr, u(), alpha(), out);
        enhance::enhance_span(&fr, u(), u(), alpha(), out);
        black_box(enhance::enhance(&fr, alpha(), out));
        let plane = buffer!(u8, 4096, 0);
        let mut grid = vorl_core::pixels::platform::PlatformGrid::<32>::new();
        let _ = black_box(vorl_core::pixels::platform::estimate_platform(
            &fr,
            alpha(),
            plane,
            &mut grid,
        ));
        let _ = black_box(vorl_core::pixels::platform::cell_size(u(), u(), u()));
        let _ = black_box(vorl_core::pixels::exposure::fit_exposure_rounds(
            &fr,
            alpha(),
            plane,
            u(),
        ));
        if let Ok(e) = black_box(vorl_core::pixels::exposure::fit_exposure(&fr, alpha(), plane)) {
            let undone = buffer!(u8, 4096, 0);
            e.undo(undone);
            black_box(e.undo_table());
        }
        black_box(vorl_core::math::nth_smallest(buffer!(f32, 64, 0.0), u()));
        black_box(vorl_core::math::select_nth(buffer!(f32, 64, 0.0), u()));
        black_box(vorl_core::pixels::platform::sample_step(u()));
        black_box(vorl_core::pose::refine::wall_facing(p2(), p2()));
        let bg_plane = buffer!(u8, 4096, 0);
        if let Ok(mut bg) = Background::new(bg_plane, u(), u()) {
            let _ = black_box(bg.set_from_frame(&fr, alpha()));
            let labels = buffer!(u8, 4096, 0);
            let _ = black_box(mask::foreground_mask(
                &fr,
                &bg,
                alpha(),
                threshold(),
                polarity(),
                cleanup(),
                labels,
            ));
            let mut spans = RowSpans::new();
            let _ = black_box(mask::foreground_mask_spans(
                &fr,
                &bg,
                alpha(),
                threshold(),
                polarity(),
                cleanup(),
                labels,
                &mut spans,
            ));
            black_box(spans.row(u()));
        }
        let bg = buffer!(u8, 4096, 0);
        let diff = Difference::new(&fr, bg, alpha());
        black_box(diff.at(isize_(), isize_()));
        black_box(diff.rows(u()));
        black_box(diff.bilinear(f(), f()));
        let rp = refine_params();
        black_box(diff.edge_offset(p2(), p2(), &rp));
        black_box(diff.edge_finder(&rp).offset(p2(), p2()));
        if let Some(ray) = ProfileRay::new(p2(), p2(), f(), i32_()) {
            black_box(ray.at(i32_()));
            black_box(refine::sample_by_pixels(&diff, &ray, i32_()));
        }
        let edge = pairs2();
        let normals = pairs2();
        black_box(refine::align(&diff, edge, normals, pose_(), &rp));
        let mask = buffer!(u8, 4096, 0);
        black_box(partial_volume_centroid(&diff, mask, (u(), u()), rect()));
        black_box(partial_volume_moments(&diff, mask, (u(), u()), rect()));
        let (print, keep_off) = (points(), points());
        black_box(print_deficit(
            &diff,
            mask,
            f(),
            [&*print, &*keep_off].into_iter(),
            core::iter::once(&*keep_off),
        ));
        // Stereo: the right image's difference, and the disparity fit along an outline.
        let right_data = buffer!(u8, 4096, 0);
        let right_bg = buffer!(u8, 4096, 0);
        if let Some(rf) = frame(right_data) {
            let right = Difference::new(&rf, right_bg, alpha());
            let dp = disparity_params();
            let _ = black_box(stereo::refine_disparity(&diff, &right, pairs2(), f(), &dp));
            let _ = black_box(stereo::refine_disparity(&diff, &right, points(), f(), &dp));
        }
    }
    let hist: &mut [u32; 256] = black_box(unsafe_free_hist());
    black_box(mask::otsu_level(hist));
    black_box(RowSpans::full(u(), u()).row(u()));
    let _ = black_box(FrameBuffer::<4096>::new(u(), u()).map(|b| {
        black_box(b.pixels().len());
        black_box(b.frame().width())
    }));
}

fn unsafe_free_hist() -> &'static mut [u32; 256] {
    static mut HIST: [u32; 256] = [0; 256];
    // SAFETY: borrowed once per call of `_start`'s body.
    black_box(unsafe { &mut *addr_of_mut!(HIST) })
}

fn borders() {
    let labels = buffer!(u8, 4096, 0);
    let filter = BorderFilter {
        min_points: u(),
        min_area: f(),
    };
    let mut store = ContourStore::<256, 8>::new();
    let _ = black_box(contour::trace_borders(labels, u(), u(), filter, &mut store));
    let mut spans = RowSpans::full(u(), u());
    if flag() {
        spans = RowSpans::new();
    }
    let _ = black_box(contour::trace_borders_in(labels, u(), u(), &spans, filter, &mut store));
    contour::clear_labels(labels, u(), u(), &spans);
    let mut big = ContourStore::<4096, 64>::new();
    let _ = black_box(contour::trace_borders_in(labels, u(), u(), &spans, filter, &mut big));
    let i = u();
    black_box(big.points(i));
    black_box(big.largest_outer());
    black_box(big.holes_of(i).count());
    store.clear();
    // Geometry of borders: area centroid, resampling, descriptors, templates.
    let border = points();
    let hole = points();
    black_box(pose::area_centroid(border, core::iter::once(&*hole)));
    let out = pairs2();
    let _ = black_box(resample::resample(border, out));
    let _ = black_box(resample::check_counts(u(), u()));
    let desc = floats();
    let dp = DescriptorParams { k: u(), omega: f() };
    let _ = black_box(descriptor::describe(out, dp, desc));
    black_box(descriptor::centroid(out));
    black_box(descriptor::scaled_k(u(), u(), u()));
    black_box(refine::outward_normal(out, u(), flag()));
    let outline = Outline::new(out);
    black_box(outline.capped_distance(p2(), f()));
    let _ = black_box(params().validate());
    black_box(params().descriptor(u()));
    black_box(params().filter());
    black_box(params().alpha());
    let p = params();
    // Holes: measured from any border, matched through any pose.
    black_box(holes::Hole::from_border(hole));
    let mut part_holes = holes::Holes::from_borders(core::iter::once(&*hole), f());
    part_holes.insert(holes::Hole {
        centre: p2(),
        area: f(),
    });
    let moved = part_holes.relative_to(p2());
    black_box(holes::agreement(&moved, &pose_(), &part_holes).missing());
    black_box(holes::pose_from_holes(&moved, &part_holes));
    black_box(holes::resolvable(f()));
    let sight = holes::Sight {
        hidden: f(),
        filter: BorderFilter {
            min_points: u(),
            min_area: f(),
        },
    };
    black_box(holes::solid_where_a_hole_is(
        &moved,
        &pose_(),
        &part_holes,
        &sight,
        || flag().then(f),
        |_, _| f(),
        |_, _| flag(),
        |_, _| f(),
    ));
    // The edge blur over any outline, any sampler.
    black_box(holes::edge_blur(out.iter().map(|&p| (p, p2())), u(), |_, _| f()));
    // A shadow's depth beside any outline, any reach, any sampler.
    black_box(holes::shade(out.iter().map(|&p| (p, p2())), u(), f(), |_, _| f()));
    black_box(polarity().difference(u8_(), u8_()));
    let agreed = holes::agreement(&moved, &pose_(), &part_holes);
    black_box(&agreed);
    black_box((part_holes.as_slice(), part_holes.len(), part_holes.is_empty()));
    if let Ok(mut t) = Template::<96>::from_border(border, core::iter::once(&*hole), &p) {
        let _ = black_box(t.set_edge(pairs2(), pairs2(), p2()));
        t.set_holes(part_holes);
        black_box(t.holes());
        black_box((t.edge(), t.normals(), t.position_offset(), t.points(), t.descriptor()));
        black_box((
            t.sorted_descriptor(),
            t.centroid(),
            t.area_centroid(),
            t.area(),
            t.len(),
        ));
        black_box((t.mirror_gap(), t.mirror_score(), t.is_chiral()));
        let mirrored = t.mirrored();
        black_box(&mirrored);
        t.mirror_from(&mirrored);
        black_box(&t);
    }
    let tp = pairs2();
    let td = floats();
    if let Ok(mut t) = Template::<8>::from_parts(tp.iter().copied(), td.iter().copied(), p2(), p2(), f()) {
        let _ = black_box(t.set_edge(pairs2(), pairs2(), p2()));
        black_box(t.sorted_descriptor());
    }
}

fn dp() {
    let part = floats();
    let template = floats();
    let row = floats();
    let table = floats();
    let assignment = buffer!(u16, 512, 0);
    black_box(matching::table_cells(u(), u()));
    black_box(matching::search_cells(u(), u()));
    let _ = black_box(matching::best_cost(part, template, f(), row));
    let _ = black_box(matching::sorted_lower_bound(part, template, f(), row));
    black_box(matching::sorted_window_bound(part, template));
    let _ = black_box(matching::match_at_start(part, template, u(), table, assignment));
    let _ = black_box(matching::match_with_assignment(part, template, table, assignment));
    let _ = black_box(matching::best_match(part, template, f(), table, assignment));
    // The pose from a correspondence.
    let (pp, tp) = (pairs2(), pairs2());
    black_box(pose::angle_paper(pp, p2(), tp, p2(), assignment));
    black_box(pose::angle_signed(pp, p2(), tp, p2(), assignment));
    black_box(pose::angle_signed_refined(pp, p2(), tp, p2(), assignment));
    let pose = pose_();
    black_box(pose.apply(p2()));
    black_box(pose.rotate(p2()));
    black_box(pose.invert(p2()));
    black_box(pose.invert_sc((f(), f()), p2()));
}

fn stereo_and_calibration() {
    if let Ok(rig) = StereoRig::new(f(), f(), f(), f()) {
        let _ = black_box(rig.depth(f()));
        let _ = black_box(rig.disparity(f()));
        let _ = black_box(rig.point(f(), f(), f()));
        black_box((rig.f_px(), rig.baseline_mm(), rig.principal_point()));
    }
    let part = || StereoPart {
        class: if flag() { Some(u16_()) } else { None },
        x: f(),
        y: f(),
        angle_deg: f(),
    };
    let left = buffer!(
        StereoPart,
        80,
        StereoPart {
            class: None,
            x: 0.0,
            y: 0.0,
            angle_deg: 0.0
        }
    );
    let right = buffer!(
        StereoPart,
        80,
        StereoPart {
            class: None,
            x: 0.0,
            y: 0.0,
            angle_deg: 0.0
        }
    );
    if let Some(p) = left.first_mut() {
        *p = part();
    }
    let pp = PairParams {
        row_tolerance_px: f(),
        max_disparity_px: f(),
    };
    let _ = black_box(pp.validate());
    let _ = black_box(disparity_params().validate());
    let out = buffer!(PairOutcome, 80, PairOutcome::Unpaired(stereo::Unpaired::NonFinite));
    let _ = black_box(stereo::pair_parts(left, right, &pp, out));
    for o in out.iter() {
        black_box(o.paired());
    }
    #[cfg(feature = "calibration-fits")]
    {
        let h2 = buffer!(([f32; 2], [f32; 2]), 64, ([0.0; 2], [0.0; 2]));
        if let Ok((h, _)) = Homography::fit(h2) {
            black_box(h.map(p2()));
            black_box(h.map_angle(p2(), f()));
            black_box(h.mirrored(p2()));
            black_box(h.matrix());
        }
        let r3 = buffer!(([f32; 3], [f32; 3]), 64, ([0.0; 3], [0.0; 3]));
        if let Ok((t, _)) = RigidTransform::fit(r3) {
            black_box(t.map(p3()));
            black_box((t.rotation(), t.translation()));
        }
    }
    let m = [p3(), p3(), p3()];
    if let Ok(h) = Homography::from_matrix(m) {
        black_box(h.map(p2()));
        black_box(h.map_angle(p2(), f()));
        black_box(h.mirrored(p2()));
    }
    if let Ok(t) = RigidTransform::from_parts([p3(), p3(), p3()], p3()) {
        black_box(t.map(p3()));
    }
}

fn budget() {
    use vorl_core::budget::{self, Capacities, Layout};
    let layout = if flag() { Layout::CORTEX_M } else { Layout::NATIVE };
    black_box(budget::template_bytes(layout, u()));
    black_box(budget::contour_store_bytes(layout, u(), u()));
    black_box(budget::recognizer_bytes(layout, u(), u(), u(), u(), u()));
    let caps = Capacities::for_points(u(), u(), u(), u(), u(), u(), u());
    black_box(budget::budget(layout, caps));
}

fn math() {
    use vorl_core::math;
    black_box(math::sqrt(f()));
    black_box(math::atan2(f(), f()));
    black_box(math::acos_clamped(f()));
    black_box(math::sin_cos(f()));
    black_box(math::round(f()));
    black_box(math::floor(f()));
    black_box(math::hypot(f(), f()));
    black_box(math::degrees(f()));
    black_box(math::radians(f()));
    black_box(math::wrap_degrees(f()));
}

static mut FIRMWARE: Firmware = Firmware::new();
static mut TINY: Tiny = Tiny::new();

#[no_mangle]
pub extern "C" fn _start() -> ! {
    // SAFETY: the only borrows of the two statics.
    let (firmware, tiny) = unsafe { (&mut *addr_of_mut!(FIRMWARE), &mut *addr_of_mut!(TINY)) };
    loop {
        match word() % 8 {
            0 => recognizer(firmware),
            1 => recognizer(tiny),
            2 => library_entry(firmware),
            3 => library_entry(tiny),
            4 => pixels(),
            5 => borders(),
            6 => dp(),
            _ => {
                stereo_and_calibration();
                budget();
                math();
            }
        }
    }
}
