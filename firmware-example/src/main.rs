//! vorl on a Cortex-M4F: the whole pipeline over fixture frames in flash, no heap.
//!
//! Runs on QEMU's `mps2-an386` board (`cargo run --release`, see `.cargo/config.toml`) or any
//! Cortex-M4F with 1 MiB of flash and 256 KiB of RAM (`memory.x` at the workspace's top level):
//!
//! 1. measures what one SysTick tick is worth in instructions (a register-only loop of known
//!    length), so the counts below are checked, not assumed;
//! 2. reads the template library (`fixtures/templates.vtl`, written on the host by
//!    `vorl templates export`) with full validation and loads it into the recognizer;
//! 3. learns the mean background from the empty-platform fixture frames;
//! 4. runs every QVGA fixture frame through the recognizer, timing each stage, then again with
//!    `refine = Off` (the paper's path) for the cost of the refine-and-verify stage, and with
//!    `candidates = 1` (only the first candidate of the bound order aligned and verified);
//!    then the frame of touching parts (`fixtures/frame_touching.gray`: two parts lying against
//!    each other, a key upside down and a part apart) with the partial search on
//!    (`touching_parts`, on by default since 2026-12-06; the three frames above run with it too);
//! 5. prints every line over semihosting in the stable format below and exits with status 0
//!    (any error: status 1; a panic: its message and status 1).
//!
//! All buffers are `static`: the background plane, the label plane and the recognizer (with
//! its templates, contour store, part buffers and DP table). There is no global allocator, so any
//! use of `alloc` anywhere in the program (the core included) fails the link: this program is the
//! project's proof that the core needs no heap. Their size is checked at compile time against
//! `vorl_core::budget` (what `vorl budget` prints) and the test compares it with the linker's
//! `.data + .bss`.
//!
//! # Output (one record per line, `key=value` fields separated by single spaces)
//!
//! ```text
//! vorl-firmware version=1
//! calibration_refclk spin_instructions=10000000 ticks=10000 instructions_per_tick=1000
//! calibration spin_instructions=10000000 ticks=250000 instructions_per_tick=40 icount=1
//! config width=320 height=240 n=64 m=96 k=4 omega=0.5 templates=8 T=8 M=96 P=4096 C=64 D=2112
//! memory static_ram=204488 recognizer=50888 planes=153600 stack_reserve=24576 stack_peak_after_library=…
//! template index=0 name=arrow
//! background frames=2 instructions=…
//! frame name=frame_0 parts=4 borders=4 foreground=… threshold=15
//! det frame=frame_0 part=0 template=0 class=arrow x=… y=… angle=… angle_paper=… score=… area=… edge=0 flipped=0 touching=0 visible=1.0000
//! instructions frame=frame_0 mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
//! instructions_refine_off frame=frame_0 mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
//! instructions_one_candidate frame=frame_0 mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
//! frame_touching name=frame_touching parts=4 borders=3 foreground=… threshold=15
//! det_touching frame=frame_touching part=0 template=2 class=key … flipped=1 touching=0 visible=1.0000
//! instructions_touching frame=frame_touching mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
//! summary frames=3 detections=12 instructions_total=… stack_peak=… stack_peak_frames=…
//! ```
//!
//! `template=-` and `class=unknown` mark a part that matches no template (`best=` then names the
//! nearest). Instruction counts are QEMU guest instructions (`-icount shift=0`: one instruction per
//! nanosecond of virtual time; the board's SysTick counts its 25 MHz processor clock, so one tick
//! is 40 instructions — measured by the `calibration` line; its 1 MHz reference clock would be
//! 1000), not the cycles of any real chip; their resolution is one tick.

#![no_std]
#![no_main]
#![forbid(unsafe_code)]

use core::mem::size_of;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hprintln;
use static_cell::ConstStaticCell;
use panic_semihosting as _;
use vorl_core::pixels::background::{Background, PlatformKeeping, PlatformUse, DEFAULT_KEEP_FRAMES};
use vorl_core::budget::{budget, Budget, Capacities, Layout};
use vorl_core::borders::contour::Contour;
use vorl_core::library::Library;
use vorl_core::shape::matching::table_cells;
use vorl_core::params::Refine;
use vorl_core::pixels::platform::{PlatformGrid, PlatformStats};
use vorl_core::recognizer::Stage;
use vorl_core::{Error, Frame, Params, Recognizer, Report, Template};

/// Frame width (QVGA).
const W: usize = 320;
/// Frame height (QVGA).
const H: usize = 240;
/// Pixels of a frame-sized plane.
const PLANE: usize = W * H;
/// Templates the recognizer holds, `T`.
const T: usize = 8;
/// Points of a part contour, `n` (the library must agree).
const N: usize = 64;
/// Template point capacity, `M` (= `m`).
const M: usize = 96;
/// Border points stored per frame, `P`.
const P: usize = 4096;
/// Borders kept per frame, `C`.
const C: usize = 64;
/// DP table cells, `D = n·(m − n + 1)`.
const D: usize = table_cells(N, M);

/// Cells of the platform grid, `G`: a QVGA frame is 20×15 cells of 16 px
/// (`vorl_core::pixels::platform::cell_size`), the same grid as the host's, so both estimate the same
/// platform.
const G: usize = 300;

/// The recognizer of this firmware.
type Rec = Recognizer<T, M, P, C, D>;

/// The capacities as `vorl budget` sees them.
const CAPS: Capacities = Capacities::for_points(W, H, N, M, T, P, C);
/// The budget `vorl budget --width 320 --height 240 --points 64 --template-points 96 --templates 8
/// --max-contours 64` prints.
const BUDGET: Budget = budget(Layout::CORTEX_M, CAPS);

// The budget calculator's layout of this target is the compiler's: if a struct of the core
// changes, this firmware stops building until `vorl_core::budget` follows.
const _: () = assert!(
    Layout::CORTEX_M.word == size_of::<usize>(),
    "vorl_core::budget::Layout::CORTEX_M.word is not size_of::<usize>(): update core/src/budget.rs"
);
const _: () = assert!(
    Layout::CORTEX_M.params == size_of::<Params>(),
    "vorl_core::budget::Layout::CORTEX_M.params is not size_of::<Params>() on Cortex-M: update core/src/budget.rs"
);
const _: () = assert!(
    Layout::CORTEX_M.contour == size_of::<Contour>(),
    "vorl_core::budget::Layout::CORTEX_M.contour is not size_of::<Contour>() on Cortex-M: update core/src/budget.rs"
);
const _: () = assert!(
    vorl_core::budget::template_bytes(Layout::CORTEX_M, M) == size_of::<Template<M>>(),
    "vorl_core::budget::template_bytes is not size_of::<Template<M>>(): update core/src/budget.rs to the fields of Template"
);
const _: () = assert!(
    BUDGET.recognizer == size_of::<Rec>(),
    "vorl_core::budget::recognizer_bytes is not size_of::<Recognizer<..>>(): update core/src/budget.rs to the fields of Recognizer"
);
const _: () = assert!(BUDGET.total == 2 * PLANE + size_of::<Rec>());
const _: () = assert!(
    PlatformGrid::<G>::BYTES == size_of::<PlatformGrid<G>>(),
    "vorl_core::pixels::platform::PlatformGrid::BYTES is not its size: update core/src/pixels/platform.rs"
);

/// Bytes aligned to 8: frames and planes start on a word boundary, as a camera's DMA buffers
/// do, so row copies take the word-wise path of `memcpy` whatever the layout of the image
/// (unaligned, a QVGA frame's mask stage costs about 200 000 more instructions).
#[repr(C, align(8))]
struct Aligned<const N: usize>([u8; N]);

/// The recognizer (`.data`: its parameters are not zero). The buffers are [`ConstStaticCell`]s:
/// built in place at compile time (a 70 KB recognizer or a 75 KB plane never passes through the
/// stack), handed out once by [`take_buffers`], without `unsafe`.
static RECOGNIZER: ConstStaticCell<Rec> = ConstStaticCell::new(Rec::new());
/// The background model's plane (`.bss`).
static BACKGROUND: ConstStaticCell<Aligned<PLANE>> = ConstStaticCell::new(Aligned([0; PLANE]));
/// The label plane: mask and border labels; the high byte of the sum while learning (`.bss`).
static LABELS: ConstStaticCell<Aligned<PLANE>> = ConstStaticCell::new(Aligned([0; PLANE]));
/// The platform estimate's cells, for frames without an empty shot (`.bss`, `9·G` bytes).
static PLATFORM: ConstStaticCell<PlatformGrid<G>> = ConstStaticCell::new(PlatformGrid::new());

/// The template library, written on the host by `vorl templates export`.
static LIBRARY: &[u8] = include_bytes!("../fixtures/templates.vtl");
/// Captures of the empty platform (8-bit gray, row-major; the type checks their size).
static BACKGROUND_0: Aligned<PLANE> = Aligned(*include_bytes!("../fixtures/background_0.gray"));
static BACKGROUND_1: Aligned<PLANE> = Aligned(*include_bytes!("../fixtures/background_1.gray"));
/// Scenes: four parts each.
static FRAME_0: Aligned<PLANE> = Aligned(*include_bytes!("../fixtures/frame_0.gray"));
static FRAME_1: Aligned<PLANE> = Aligned(*include_bytes!("../fixtures/frame_1.gray"));
static FRAME_2: Aligned<PLANE> = Aligned(*include_bytes!("../fixtures/frame_2.gray"));
/// The background captures by name.
static BACKGROUNDS: [(&str, &Aligned<PLANE>); 2] = [("background_0", &BACKGROUND_0), ("background_1", &BACKGROUND_1)];
/// The scenes by name.
static FRAMES: [(&str, &Aligned<PLANE>); 3] = [("frame_0", &FRAME_0), ("frame_1", &FRAME_1), ("frame_2", &FRAME_2)];
/// Two parts lying against each other, one upside down and one apart: run with the partial
/// search on ([`Params::touching_parts`]).
static FRAME_TOUCHING: Aligned<PLANE> = Aligned(*include_bytes!("../fixtures/frame_touching.gray"));

/// QEMU `-icount shift=0` runs one guest instruction per nanosecond of virtual time, and the
/// mps2-an386 SysTick counts the 25 MHz processor clock: 1e9 / 25e6 = 40 instructions per tick.
const NOMINAL_INSTRUCTIONS_PER_TICK: u64 = 40;
/// Stack kept free above the static buffers (`_vorl_min_stack` in memory.x).
const STACK_RESERVE: usize = 24 * 1024;
/// Iterations of the calibration loop (two instructions each).
const SPIN_ITERATIONS: u32 = 5_000_000;

/// SysTick wraps (every 2^24 ticks).
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Ticks since the timer started: wraps and the down-counter, read consistently.
fn ticks() -> u64 {
    loop {
        let wraps = WRAPS.load(Ordering::SeqCst);
        let value = SYST::get_current();
        if WRAPS.load(Ordering::SeqCst) == wraps {
            return (u64::from(wraps) << 24) | u64::from(0x00FF_FFFF - value);
        }
    }
}

/// (Re)starts SysTick from zero on `source`, counting down from 2^24 − 1 with an interrupt per
/// wrap, and returns once the counter has loaded (so [`ticks`] starts at 0 and only grows).
fn start_systick(syst: &mut SYST, source: SystClkSource) {
    syst.disable_counter();
    syst.set_clock_source(source);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    WRAPS.store(0, Ordering::SeqCst);
    syst.enable_interrupt();
    syst.enable_counter();
    // A written counter reads 0 until the next clock edge reloads it (without a wrap interrupt).
    let mut guard = 0u32;
    while SYST::get_current() == 0 && guard < 1_000_000 {
        guard += 1;
    }
}

/// Exactly `2·iterations` instructions (and the few of the loop's alignment): the register-only
/// countdown of `cortex_m::asm::delay` (`subs`, `bne`, `cycles + 1` times).
fn spin(iterations: u32) {
    cortex_m::asm::delay(iterations.max(1) - 1);
}

/// The four static buffers, once (`None` on a second call).
#[allow(clippy::type_complexity)]
fn take_buffers() -> Option<(
    &'static mut Rec,
    &'static mut [u8; PLANE],
    &'static mut [u8; PLANE],
    &'static mut PlatformGrid<G>,
)> {
    Some((
        RECOGNIZER.try_take()?,
        &mut BACKGROUND.try_take()?.0,
        &mut LABELS.try_take()?.0,
        PLATFORM.try_take()?,
    ))
}

/// Bytes of the stack used so far: the stack was painted with `0xCCCCCCCC` at reset
/// (cortex-m-rt `paint-stack`); the lowest word no longer painted marks the peak
/// (`cortex_m_stack::stack_painted` finds it; a frame that reserves stack it never writes, or
/// writes the paint value, can hide a few words).
fn stack_peak() -> usize {
    (cortex_m_stack::stack_size() - cortex_m_stack::stack_painted()) as usize
}

#[entry]
fn main() -> ! {
    let status = match run() {
        Ok(()) => EXIT_SUCCESS,
        Err(Failure::Core(e)) => {
            hprintln!("error {}", e);
            EXIT_FAILURE
        }
        Err(Failure::Setup(what)) => {
            hprintln!("error {}", what);
            EXIT_FAILURE
        }
    };
    debug::exit(status);
    #[allow(clippy::empty_loop)]
    loop {}
}

/// Why the program stopped early.
enum Failure {
    /// The core refused an input (library, frame, parameters).
    Core(Error),
    /// The program's own set-up went wrong.
    Setup(&'static str),
}

impl From<Error> for Failure {
    fn from(e: Error) -> Self {
        Failure::Core(e)
    }
}

fn run() -> Result<(), Failure> {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        return Err(Failure::Setup("the core peripherals were taken twice"));
    };
    let Some((rec, bg_plane, labels, grid)) = take_buffers() else {
        return Err(Failure::Setup("the static buffers were taken twice"));
    };
    hprintln!("vorl-firmware version=1");
    let spin_instructions = 2 * u64::from(SPIN_ITERATIONS);
    // The board's SysTick reference clock, for the record (the counts below use the processor
    // clock, which is finer).
    start_systick(&mut core.SYST, SystClkSource::External);
    let t0 = ticks();
    spin(SPIN_ITERATIONS);
    let ref_ticks = ticks() - t0;
    hprintln!(
        "calibration_refclk spin_instructions={} ticks={} instructions_per_tick={}",
        spin_instructions,
        ref_ticks,
        (spin_instructions + ref_ticks / 2) / ref_ticks.max(1)
    );
    start_systick(&mut core.SYST, SystClkSource::Core);
    let t0 = ticks();
    spin(SPIN_ITERATIONS);
    let spin_ticks = ticks() - t0;
    let per_tick = (spin_instructions + spin_ticks / 2) / spin_ticks.max(1);
    hprintln!(
        "calibration spin_instructions={} ticks={} instructions_per_tick={} icount={}",
        spin_instructions,
        spin_ticks,
        per_tick,
        u8::from(per_tick == NOMINAL_INSTRUCTIONS_PER_TICK)
    );
    if per_tick != NOMINAL_INSTRUCTIONS_PER_TICK {
        hprintln!("warning the counts below are not instruction counts: run QEMU with -icount shift=0");
    }
    let instructions = |ticks: u64| ticks * NOMINAL_INSTRUCTIONS_PER_TICK;

    let library = load_library(rec)?;
    let stack_after_load = stack_peak();
    let p = *rec.params();
    hprintln!(
        "config width={} height={} n={} m={} k={} omega={} templates={} T={} M={} P={} C={} D={}",
        W,
        H,
        p.n,
        p.m,
        p.k,
        p.omega,
        rec.templates().len(),
        T,
        M,
        P,
        C,
        D
    );
    hprintln!(
        "memory static_ram={} recognizer={} planes={} platform_grid={} stack_reserve={} stack_peak_after_library={}",
        BUDGET.total,
        size_of::<Rec>(),
        2 * PLANE,
        size_of::<PlatformGrid<G>>(),
        STACK_RESERVE,
        stack_after_load
    );
    for i in 0..library.len() {
        hprintln!("template index={} name={}", i, library.name(i).unwrap_or("?"));
    }

    let t0 = ticks();
    let mut background = Background::new(&mut bg_plane[..], W, H)?;
    for (_, pixels) in BACKGROUNDS.iter() {
        background.learn(&Frame::new_checked(&pixels.0[..], W, H)?, p.alpha(), &mut labels[..])?;
    }
    background.finish_learning(&labels[..])?;
    hprintln!(
        "background frames={} instructions={}",
        BACKGROUNDS.len(),
        instructions(ticks() - t0)
    );

    if let Some(frames) = soak_request() {
        return soak(frames, rec, &library, bg_plane, labels, grid);
    }

    let (mut detections, mut total) = (0usize, 0u64);
    for (name, pixels) in FRAMES.iter() {
        let frame = Frame::new_checked(&pixels.0[..], W, H)?;
        let out = run_frame(
            rec,
            &frame,
            &background,
            &mut labels[..],
            Some(("frame", "det", name, &library)),
        )?;
        let counts = out.counts;
        hprintln!(
            "instructions frame={} mask={} borders={} descriptors_matching={} total={} [instructions, not cycles]",
            name,
            counts.mask,
            counts.borders,
            counts.parts,
            counts.total
        );
        detections += out.parts;
        total += counts.total;
    }
    // Two cheaper configurations for comparison (their detections are not printed): the paper's
    // path, with no alignment or verification after the DP (the cost of the refine-and-verify
    // stage is the difference), and verification of the DP's best template only.
    let stack_after_frames = stack_peak();
    let default = *rec.params();
    let lighter = [
        ("instructions_refine_off", Refine::Off, default.candidates),
        ("instructions_one_candidate", Refine::Verify, 1),
    ];
    for (label, refine, candidates) in lighter {
        rec.set_params(Params {
            refine,
            candidates,
            ..default
        })?;
        for (name, pixels) in FRAMES.iter() {
            let frame = Frame::new_checked(&pixels.0[..], W, H)?;
            let counts = run_frame(rec, &frame, &background, &mut labels[..], None)?.counts;
            hprintln!(
                "{} frame={} mask={} borders={} descriptors_matching={} total={} [instructions, not cycles]",
                label,
                name,
                counts.mask,
                counts.borders,
                counts.parts,
                counts.total
            );
        }
    }
    rec.set_params(default)?;
    touching_frame(rec, &library, &background, labels)?;

    let (detections_auto, total_auto) = estimated_frames(rec, &library, bg_plane, labels, grid)?;
    hprintln!(
        "summary frames={} detections={} instructions_total={} detections_auto={} instructions_total_auto={} stack_peak={} stack_peak_frames={}",
        FRAMES.len(),
        detections,
        total,
        detections_auto,
        total_auto,
        stack_peak(),
        stack_after_frames
    );
    Ok(())
}

/// The frame of touching parts with the partial search on ([`Params::touching_parts`], the
/// default, set here all the same): its `frame_touching` line, `det_touching` detections and
/// `instructions_touching` counts (not in the `summary` line's totals, which are the three
/// frames' with the defaults). The defaults are back on return.
#[inline(never)]
fn touching_frame(
    rec: &mut Rec,
    library: &Library<'_>,
    background: &Background<&mut [u8]>,
    labels: &mut [u8; PLANE],
) -> Result<(), Failure> {
    let default = *rec.params();
    rec.set_params(Params {
        touching_parts: true,
        ..default
    })?;
    let name = "frame_touching";
    let frame = Frame::new_checked(&FRAME_TOUCHING.0[..], W, H)?;
    let out = run_frame(
        rec,
        &frame,
        background,
        &mut labels[..],
        Some(("frame_touching", "det_touching", name, library)),
    );
    rec.set_params(default)?;
    let out = out?;
    let counts = out.counts;
    hprintln!(
        "instructions_touching frame={} mask={} borders={} descriptors_matching={} total={} [instructions, not cycles]",
        name,
        counts.mask,
        counts.borders,
        counts.parts,
        counts.total
    );
    Ok(())
}

/// No empty shot: the platform estimated from the frames themselves, into the background plane
/// (the learned model is gone after this): from the first, and kept for the next ones while
/// they fit it ([`Background::estimate_or_keep`], as the host does); then the frame through the
/// recognizer. Returns the detections and the instructions (estimate or exposure check
/// included). Its own stack frame: the report is
/// not kept beside the other calls' in `run`'s.
#[inline(never)]
fn estimated_frames(
    rec: &mut Rec,
    library: &Library<'_>,
    bg_plane: &mut [u8; PLANE],
    labels: &mut [u8; PLANE],
    grid: &mut PlatformGrid<G>,
) -> Result<(usize, u64), Failure> {
    let alpha = rec.params().alpha();
    let instructions = |ticks: u64| ticks * NOMINAL_INSTRUCTIONS_PER_TICK;
    let (mut detections_auto, mut total_auto) = (0usize, 0u64);
    let mut estimated = Background::new(&mut bg_plane[..], W, H)?;
    let mut keeping = PlatformKeeping::new(DEFAULT_KEEP_FRAMES);
    for (name, pixels) in FRAMES.iter() {
        let frame = Frame::new_checked(&pixels.0[..], W, H)?;
        let t0 = ticks();
        let used = estimated.estimate_or_keep(&frame, alpha, grid, &mut keeping)?;
        let platform = instructions(ticks() - t0);
        let frames_ago = match used {
            PlatformUse::Kept { frames_ago, .. } => frames_ago,
            PlatformUse::Estimated(_) => 0,
        };
        print_platform(name, &used.stats(), frames_ago);
        let out = run_frame(
            rec,
            &frame,
            &estimated,
            &mut labels[..],
            Some(("frame_auto", "det_auto", name, library)),
        )?;
        let counts = out.counts;
        hprintln!(
            "instructions_auto frame={} platform={} mask={} borders={} descriptors_matching={} total={} [instructions, not cycles]",
            name,
            platform,
            counts.mask,
            counts.borders,
            counts.parts,
            platform + counts.total
        );
        detections_auto += out.parts;
        total_auto += platform + counts.total;
    }
    Ok((detections_auto, total_auto))
}

/// What the platform estimate found (`platform` line).
#[inline(never)]
fn print_platform(name: &str, s: &PlatformStats, frames_ago: u32) {
    hprintln!(
        "platform frame={} frames_ago={} cell={} cells_x={} cells_y={} with_level={} kept={} degree={} outlier={:.2} range={:.1},{:.1}",
        name,
        frames_ago,
        s.cell,
        s.cells_x,
        s.cells_y,
        s.with_level,
        s.kept,
        s.degree,
        s.outlier,
        s.range[0],
        s.range[1]
    );
}

/// One `<tag> frame=… part=…` line per detection and one `skip` line per skipped border.
#[inline(never)]
fn print_detections(tag: &str, name: &str, report: &Report, library: &Library<'_>) {
    for (i, d) in report.detections.iter().enumerate() {
        let class = d.template.and_then(|t| library.name(usize::from(t)));
        let best = d
            .best_template
            .and_then(|t| library.name(usize::from(t)))
            .unwrap_or("-");
        match d.template {
            Some(t) => hprintln!(
                "{} frame={} part={} template={} class={} x={:.4} y={:.4} angle={:.4} angle_paper={:.4} score={:.6} area={:.1} edge={} flipped={} touching={} visible={:.4}",
                tag,
                name,
                i,
                t,
                class.unwrap_or("?"),
                d.x,
                d.y,
                d.angle_deg,
                d.angle_paper_deg,
                d.score,
                d.area,
                u8::from(d.touches_edge),
                u8::from(d.flipped),
                u8::from(d.touching),
                d.visible_fraction
            ),
            None => hprintln!(
                "{} frame={} part={} template=- class=unknown best={} x={:.4} y={:.4} angle={:.4} angle_paper={:.4} score={:.6} area={:.1} edge={} flipped=0 touching={} visible={:.4}",
                tag,
                name,
                i,
                best,
                d.x,
                d.y,
                d.angle_deg,
                d.angle_paper_deg,
                d.score,
                d.area,
                u8::from(d.touches_edge),
                u8::from(d.touching),
                d.visible_fraction
            ),
        }
    }
    for s in report.skips.iter() {
        hprintln!("skip frame={} border={} reason={:?}", name, s.contour, s.reason);
    }
}

/// Instruction counts of one frame's stages.
struct Counts {
    /// Mask: enhancement, difference, threshold, clean-up.
    mask: u64,
    /// Border following.
    borders: u64,
    /// Every part: resampling, descriptor, DP matching, refine and verify, pose.
    parts: u64,
    /// The whole call.
    total: u64,
}

/// Parses the template library and loads it into the recognizer. Not inlined: the templates
/// that pass through the stack while loading do not stay in `run`'s frame.
#[inline(never)]
fn load_library(rec: &mut Rec) -> Result<Library<'static>, Error> {
    let library = Library::parse(LIBRARY)?;
    rec.load_library(&library)?;
    Ok(library)
}

/// What a caller keeps of a frame: the counts and a fingerprint, not the report.
struct Outcome {
    /// Detections.
    parts: usize,
    /// Instructions per stage.
    counts: Counts,
    /// [`fingerprint`] of the report.
    fingerprint: u64,
}

/// One frame through the recognizer ([`timed`]); with `print` = (frame tag, detection tag,
/// name, library) its `frame` line and detections are printed. Not inlined: the report (about
/// 5 KiB) lives in this one stack frame, not once per call site in the callers'.
#[inline(never)]
fn run_frame(
    rec: &mut Rec,
    frame: &Frame<&[u8]>,
    background: &Background<&mut [u8]>,
    labels: &mut [u8],
    print: Option<(&str, &str, &str, &Library<'_>)>,
) -> Result<Outcome, Error> {
    let (report, counts) = timed(rec, frame, background, labels)?;
    if let Some((frame_tag, det_tag, name, library)) = print {
        hprintln!(
            "{} name={} parts={} borders={} foreground={} threshold={}",
            frame_tag,
            name,
            report.detections.len(),
            report.trace.kept,
            report.mask.foreground,
            report.mask.threshold
        );
        print_detections(det_tag, name, &report, library);
    }
    Ok(Outcome {
        parts: report.detections.len(),
        counts,
        fingerprint: fingerprint(&report),
    })
}

/// Runs one frame through the recognizer, counting each stage's instructions. Inlined into
/// [`run_frame`] so the report is not copied through another stack frame.
#[inline(always)]
fn timed(
    rec: &mut Rec,
    frame: &Frame<&[u8]>,
    background: &Background<&mut [u8]>,
    labels: &mut [u8],
) -> Result<(vorl_core::Report, Counts), Error> {
    let mut marks = [0u64; 3];
    let start = ticks();
    let report = rec.process_observed(frame, background, labels, |stage| {
        let now = ticks();
        match stage {
            Stage::Mask => marks[0] = now,
            Stage::Borders => marks[1] = now,
            Stage::Parts => marks[2] = now,
            _ => {}
        }
    })?;
    let end = ticks();
    let instructions = |ticks: u64| ticks * NOMINAL_INSTRUCTIONS_PER_TICK;
    let counts = Counts {
        mask: instructions(marks[0] - start),
        borders: instructions(marks[1] - marks[0]),
        parts: instructions(marks[2] - marks[1]),
        total: instructions(end - start),
    };
    Ok((report, counts))
}

// ---------------------------------------------------------------------------------------------
// Soak run: `qemu-system-arm … -kernel vorl-firmware-example -append "soak 10000"`.

/// Most frames a soak run takes.
const SOAK_MAX: u32 = 10_000_000;
/// The soak's scenes: the three fixture frames and an empty platform.
static SOAK_SCENES: [(&str, &Aligned<PLANE>); 4] = [
    ("frame_0", &FRAME_0),
    ("frame_1", &FRAME_1),
    ("frame_2", &FRAME_2),
    ("background_0", &BACKGROUND_0),
];
/// The soak's views of a scene: (x0, y0, width, height, platform estimated). The empty-shot
/// view is the whole frame (the learned model is full size); the estimated ones are the whole
/// frame and a 272×208 window (a crop through the row stride, cutting parts at its edge).
const SOAK_VIEWS: [(usize, usize, usize, usize, bool); 3] =
    [(0, 0, W, H, false), (0, 0, W, H, true), (24, 16, 272, 208, true)];
/// The soak's parameter sets: the defaults and the paper's path.
const SOAK_REFINES: [Refine; 2] = [Refine::Verify, Refine::Off];
/// Variants: scene × view × parameters.
const SOAK_VARIANTS: usize = SOAK_SCENES.len() * SOAK_VIEWS.len() * SOAK_REFINES.len();
/// Frames between two `soak_progress` lines.
const SOAK_PROGRESS: u32 = 1000;

/// `soak N` on the semihosting command line (QEMU's `-append`): the number of frames.
#[inline(never)]
fn soak_request() -> Option<u32> {
    let mut buf = [core::mem::MaybeUninit::<u8>::uninit(); 128];
    // SYS_GET_CMDLINE: the host writes the command line into the buffer.
    let text = semihosting::sys::arm_compat::sys_get_cmdline_uninit(&mut buf).ok()?;
    let text = core::str::from_utf8(text).ok()?;
    let mut words = text.split_whitespace().skip_while(|w| *w != "soak").skip(1);
    words.next()?.parse::<u32>().ok().map(|n| n.min(SOAK_MAX))
}

/// FNV-1a over the words of a report: every detection's template, pose, scores and area bit for
/// bit, the mask's and the tracer's counts and the skips.
fn fingerprint(report: &Report) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |v: u32| {
        for b in v.to_le_bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(report.detections.len() as u32);
    eat(report.mask.foreground as u32);
    eat(report.trace.kept as u32);
    eat(report.skips.len() as u32);
    for d in report.detections.iter() {
        eat(d.template.map_or(u32::MAX, u32::from));
        eat(d.best_template.map_or(u32::MAX, u32::from));
        for v in [
            d.score,
            d.x,
            d.y,
            d.angle_deg,
            d.angle_paper_deg,
            d.verify,
            d.scale,
            d.area,
        ] {
            eat(v.to_bits());
        }
        eat(u32::from(d.contour));
        eat(u32::from(d.touches_edge));
        eat(u32::from(d.flipped));
        eat(u32::from(d.touching));
        eat(d.visible_fraction.to_bits());
    }
    for s in report.skips.iter() {
        eat(u32::from(s.contour));
    }
    h
}

/// The soak: `frames` frames through this one recognizer, each a variant drawn at random
/// (scene × view × parameters, [`SOAK_VARIANTS`] of them). The first frame of a variant
/// prints its detections (`det_soak`, for the host to compare) and its fingerprint; every later
/// frame of it must give the same fingerprint, bit for bit, or it is counted (and printed) as
/// a mismatch. The learned empty-shot model is learned again whenever the estimated views have
/// overwritten the background plane (`relearns`).
#[inline(never)]
fn soak(
    frames: u32,
    rec: &mut Rec,
    library: &Library<'_>,
    bg_plane: &mut [u8; PLANE],
    labels: &mut [u8; PLANE],
    grid: &mut PlatformGrid<G>,
) -> Result<(), Failure> {
    let default = *rec.params();
    let alpha = default.alpha();
    let mut first: [Option<(u64, usize)>; SOAK_VARIANTS] = [None; SOAK_VARIANTS];
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let (mut mismatches, mut errors, mut relearns, mut detections) = (0u32, 0u32, 0u32, 0u64);
    let (mut total, mut most, mut least) = (0u64, 0u64, u64::MAX);
    let mut learned = false;
    let mut stack_first = 0usize;
    let start = ticks();
    hprintln!("soak frames={} variants={}", frames, SOAK_VARIANTS);
    for i in 0..frames {
        // xorshift64*
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        let v = (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 33) as usize % SOAK_VARIANTS;
        let (scene, rest) = (
            v / (SOAK_VIEWS.len() * SOAK_REFINES.len()),
            v % (SOAK_VIEWS.len() * SOAK_REFINES.len()),
        );
        let (view, refine) = (rest / SOAK_REFINES.len(), rest % SOAK_REFINES.len());
        let (scene_name, pixels) = SOAK_SCENES[scene];
        let (x0, y0, w, h, estimate) = SOAK_VIEWS[view];
        rec.set_params(Params {
            refine: SOAK_REFINES[refine],
            ..default
        })?;
        let frame = Frame::with_stride(&pixels.0[y0 * W + x0..], w, h, W)?;
        let mut name = [0u8; 3];
        let tag = variant_tag(v, &mut name);
        let print = first[v].is_none().then_some(("soak_frame", "det_soak", tag, library));
        let outcome = (|| -> Result<(Outcome, u64), Error> {
            let mut bg = Background::new(&mut bg_plane[..w * h], w, h)?;
            let mut platform = 0;
            if estimate {
                learned = false;
                let t0 = ticks();
                bg.estimate_from_frame(&frame, alpha, grid)?;
                platform = NOMINAL_INSTRUCTIONS_PER_TICK * (ticks() - t0);
            } else {
                // The learned model: the mean of both empty-platform captures.
                if !learned {
                    relearns += 1;
                }
                for (_, capture) in BACKGROUNDS.iter() {
                    bg.learn(&Frame::new_checked(&capture.0[..], W, H)?, alpha, &mut labels[..])?;
                }
                bg.finish_learning(&labels[..])?;
                learned = true;
            }
            let out = run_frame(rec, &frame, &bg, &mut labels[..w * h], print)?;
            Ok((out, platform))
        })();
        match outcome {
            Err(e) => {
                errors += 1;
                hprintln!("soak_error frame={} variant={} error={}", i, v, e);
            }
            Ok((out, platform)) => {
                let count = platform + out.counts.total;
                total += count;
                most = most.max(count);
                least = least.min(count);
                detections += out.parts as u64;
                match first[v] {
                    None => {
                        first[v] = Some((out.fingerprint, out.parts));
                        hprintln!(
                            "soak_variant variant={} scene={} x0={} y0={} width={} height={} platform={} refine={} first_frame={} parts={} fingerprint={:016x} instructions={}",
                            tag,
                            scene_name,
                            x0,
                            y0,
                            w,
                            h,
                            if estimate { "estimated" } else { "empty_shot" },
                            if SOAK_REFINES[refine] == Refine::Off { "off" } else { "verify" },
                            i,
                            out.parts,
                            out.fingerprint,
                            count
                        );
                    }
                    Some((expected, _)) if expected != out.fingerprint => {
                        mismatches += 1;
                        hprintln!(
                            "soak_mismatch frame={} variant={} fingerprint={:016x} expected={:016x}",
                            i,
                            v,
                            out.fingerprint,
                            expected
                        );
                    }
                    Some(_) => {}
                }
            }
        }
        if i == 0 {
            stack_first = stack_peak();
        }
        if (i + 1) % SOAK_PROGRESS == 0 || i + 1 == frames {
            hprintln!(
                "soak_progress frames={} mismatches={} errors={} relearns={} detections={} instructions={} stack_peak={}",
                i + 1,
                mismatches,
                errors,
                relearns,
                detections,
                total,
                stack_peak()
            );
        }
    }
    rec.set_params(default)?;
    let seen = first.iter().filter(|f| f.is_some()).count();
    let elapsed = NOMINAL_INSTRUCTIONS_PER_TICK * (ticks() - start);
    hprintln!(
        "soak_summary frames={} variants={} seen={} mismatches={} errors={} relearns={} detections={} instructions_frames={} instructions_min={} instructions_max={} instructions_all={} stack_peak_first={} stack_peak={}",
        frames,
        SOAK_VARIANTS,
        seen,
        mismatches,
        errors,
        relearns,
        detections,
        total,
        if least == u64::MAX { 0 } else { least },
        most,
        elapsed,
        stack_first,
        stack_peak()
    );
    if mismatches > 0 || errors > 0 {
        return Err(Failure::Setup("the soak run lost or changed detections"));
    }
    Ok(())
}

/// `vNN`, the variant's name in `det_soak` lines.
fn variant_tag(v: usize, buf: &mut [u8; 3]) -> &str {
    buf[0] = b'v';
    buf[1] = b'0' + (v / 10 % 10) as u8;
    buf[2] = b'0' + (v % 10) as u8;
    core::str::from_utf8(buf).unwrap_or("v??")
}
