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
//! det frame=frame_0 part=0 template=0 class=arrow x=… y=… angle=… angle_paper=… score=… area=… edge=0
//! instructions frame=frame_0 mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
//! instructions_refine_off frame=frame_0 mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
//! instructions_one_candidate frame=frame_0 mask=… borders=… descriptors_matching=… total=… [instructions, not cycles]
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

use core::mem::size_of;
use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hprintln;
use panic_semihosting as _;
use vorl_core::background::Background;
use vorl_core::budget::{budget, Budget, Capacities, Layout};
use vorl_core::contour::Contour;
use vorl_core::library::Library;
use vorl_core::matching::table_cells;
use vorl_core::params::Refine;
use vorl_core::recognizer::Stage;
use vorl_core::{Error, Frame, Params, Recognizer, Template};

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

/// Bytes aligned to 8: frames and planes start on a word boundary, as a camera's DMA buffers
/// do, so row copies take the word-wise path of `memcpy` whatever the layout of the image
/// (unaligned, a QVGA frame's mask stage costs about 200 000 more instructions).
#[repr(C, align(8))]
struct Aligned<const N: usize>([u8; N]);

/// The recognizer (`.data`: its parameters are not zero).
static mut RECOGNIZER: Rec = Rec::new();
/// The background model's plane (`.bss`).
static mut BACKGROUND: Aligned<PLANE> = Aligned([0; PLANE]);
/// The label plane: mask and border labels; the high byte of the sum while learning (`.bss`).
static mut LABELS: Aligned<PLANE> = Aligned([0; PLANE]);

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

/// Exactly `2·iterations` instructions: a register-only countdown (`subs`, `bne`).
fn spin(iterations: u32) {
    // SAFETY: the loop touches one register and no memory.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) iterations.max(1) => _,
            options(nomem, nostack),
        );
    }
}

/// The three statics, once (`None` on a second call).
fn take_buffers() -> Option<(&'static mut Rec, &'static mut [u8; PLANE], &'static mut [u8; PLANE])> {
    static TAKEN: AtomicBool = AtomicBool::new(false);
    if TAKEN.swap(true, Ordering::SeqCst) {
        return None;
    }
    // SAFETY: the flag lets this block run once, so these are the only references ever made to
    // the three statics, and nothing else (no interrupt handler) touches them.
    unsafe {
        Some((
            &mut *addr_of_mut!(RECOGNIZER),
            &mut (*addr_of_mut!(BACKGROUND)).0,
            &mut (*addr_of_mut!(LABELS)).0,
        ))
    }
}

/// Bytes of the stack used so far: the stack was painted with `0xCCCCCCCC` at reset
/// (cortex-m-rt `paint-stack`); the lowest word no longer painted marks the peak (a frame that
/// reserves stack it never writes, or writes the paint value, can hide a few words).
fn stack_peak() -> usize {
    extern "C" {
        static _stack_end: u32;
        static _stack_start: u32;
    }
    // SAFETY: only the addresses of the linker's symbols are taken, then the painted RAM between
    // them (inside the RAM region, word-aligned) is read.
    #[allow(unused_unsafe)]
    let (low, high) = unsafe {
        (
            core::ptr::addr_of!(_stack_end) as usize,
            core::ptr::addr_of!(_stack_start) as usize,
        )
    };
    let mut at = low;
    while at < high {
        // SAFETY: `at` is a word-aligned address in RAM below the top of the stack.
        let word = unsafe { core::ptr::read_volatile(at as *const u32) };
        if word != 0xCCCC_CCCC {
            break;
        }
        at += 4;
    }
    high - at
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
    let Some((rec, bg_plane, labels)) = take_buffers() else {
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

    let library = Library::parse(LIBRARY)?;
    library.load_into(rec)?;
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
        "memory static_ram={} recognizer={} planes={} stack_reserve={} stack_peak_after_library={}",
        BUDGET.total,
        size_of::<Rec>(),
        2 * PLANE,
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

    let (mut detections, mut total) = (0usize, 0u64);
    for (name, pixels) in FRAMES.iter() {
        let frame = Frame::new_checked(&pixels.0[..], W, H)?;
        let (report, counts) = timed(rec, &frame, &background, &mut labels[..])?;
        hprintln!(
            "frame name={} parts={} borders={} foreground={} threshold={}",
            name,
            report.detections.len(),
            report.trace.kept,
            report.mask.foreground,
            report.mask.threshold
        );
        for (i, d) in report.detections.iter().enumerate() {
            let class = d.template.and_then(|t| library.name(usize::from(t)));
            let best = d
                .best_template
                .and_then(|t| library.name(usize::from(t)))
                .unwrap_or("-");
            match d.template {
                Some(t) => hprintln!(
                    "det frame={} part={} template={} class={} x={:.4} y={:.4} angle={:.4} angle_paper={:.4} score={:.6} area={:.1} edge={}",
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
                    u8::from(d.touches_edge)
                ),
                None => hprintln!(
                    "det frame={} part={} template=- class=unknown best={} x={:.4} y={:.4} angle={:.4} angle_paper={:.4} score={:.6} area={:.1} edge={}",
                    name,
                    i,
                    best,
                    d.x,
                    d.y,
                    d.angle_deg,
                    d.angle_paper_deg,
                    d.score,
                    d.area,
                    u8::from(d.touches_edge)
                ),
            }
        }
        for s in report.skips.iter() {
            hprintln!("skip frame={} border={} reason={:?}", name, s.contour, s.reason);
        }
        hprintln!(
            "instructions frame={} mask={} borders={} descriptors_matching={} total={} [instructions, not cycles]",
            name,
            counts.mask,
            counts.borders,
            counts.parts,
            counts.total
        );
        detections += report.detections.len();
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
            let (_, counts) = timed(rec, &frame, &background, &mut labels[..])?;
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
    hprintln!(
        "summary frames={} detections={} instructions_total={} stack_peak={} stack_peak_frames={}",
        FRAMES.len(),
        detections,
        total,
        stack_peak(),
        stack_after_frames
    );
    Ok(())
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

/// Runs one frame through the recognizer, counting each stage's instructions. Inlined so the
/// report (about 2.6 KiB) is not copied through another stack frame.
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
