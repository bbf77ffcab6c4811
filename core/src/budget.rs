//! The memory budget: the bytes of every static buffer of a configuration, before it is built.
//!
//! A camera's RAM must hold the recognizer (templates, contour store, part buffers, DP table)
//! and the two frame-sized planes the caller provides (background model and label plane). Its
//! capacities are const generics, so `size_of` gives the recognizer's size for a configuration
//! that is compiled; [`budget`] computes the same figure for capacities known only at run time
//! (`vorl budget`), and for another target than the one running it ([`Layout::CORTEX_M`] on a
//! 64-bit host). The formulas mirror the struct layouts field by field; the unit tests (and the
//! firmware example, at compile time on the MCU) hold them equal to `size_of`.
//!
//! | buffer | bytes |
//! |---|---|
//! | background plane | `w·h` |
//! | label plane | `w·h` |
//! | contour points | `4·P` |
//! | contour records | `C·size_of::<Contour>()` + the vector's length word + the store's counter |
//! | templates | `T·size_of::<Template<M>>()` + the vector's length word, `size_of::<Template<M>>() = word + 32·M + 56 + 100 + 12` (the holes, [`HOLES_BYTES`], and the class's tolerance) rounded up to the word |
//! | DP table | `4·D` (`D ≥ n·(m − n + 1)`) |
//! | part buffers | `22·M`: points `8·M`, descriptor `4·M`, correspondence `2·M`, sub-pixel edge `8·M`; one template, the mirror image a part upside down is matched against; the partial search's blob border and open DP, `12·BLOB_POINTS + 4·M·(ARC_ROWS + 2)` ([`split_buffer_bytes`]) |
//! | parameters, padding | `size_of::<Params>()` and the rounding of the recognizer to its alignment |
//!
//! The frame itself is not counted: in the firmware example it is in flash; on a camera it is the
//! sensor's DMA buffer (`w·h` more bytes of RAM, [`Budget::frame`]). The stack is not counted
//! either.
//!
//! ```
//! use vorl_core::budget::{budget, Capacities, Layout};
//! use vorl_core::Recognizer;
//! // Formula and compiler agree for a configuration that is compiled:
//! let caps = Capacities { width: 320, height: 240, templates: 8, template_points: 96, border_points: 4096, contours: 64, dp_cells: 2112 };
//! let b = budget(Layout::NATIVE, caps);
//! assert_eq!(b.recognizer, core::mem::size_of::<Recognizer<8, 96, 4096, 64, 2112>>());
//! assert_eq!(b.total, 2 * 320 * 240 + b.recognizer);
//! // On a Cortex-M4 the same configuration fits in 256 KiB of RAM with room for the stack:
//! assert!(budget(Layout::CORTEX_M, caps).total + 16 * 1024 <= 256 * 1024);
//! ```

use core::mem::{align_of, size_of};

use crate::borders::contour::Contour;
use crate::params::Params;
use crate::shape::matching::table_cells;

/// The sizes and alignments that differ from one target to another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Name of the target, for reports.
    pub name: &'static str,
    /// `size_of::<usize>()` (and its alignment).
    pub word: usize,
    /// `size_of::<Params>()`.
    pub params: usize,
    /// `size_of::<Contour>()`.
    pub contour: usize,
    /// `align_of::<Contour>()` (it holds an `i64`: 8 on both 32-bit ARM and 64-bit hosts).
    pub contour_align: usize,
}

impl Layout {
    /// 32-bit Arm Cortex-M (`thumbv6m`/`thumbv7em`/`thumbv8m`): 4-byte `usize`, 8-byte aligned
    /// `i64`. The firmware example checks these figures against `size_of` at compile time.
    pub const CORTEX_M: Layout = Layout {
        name: "Cortex-M (32-bit)",
        word: 4,
        params: 72,
        contour: 32,
        contour_align: 8,
    };

    /// The target this crate is compiled for, from `size_of` and `align_of`.
    pub const NATIVE: Layout = Layout {
        name: "native",
        word: size_of::<usize>(),
        params: size_of::<Params>(),
        contour: size_of::<Contour>(),
        contour_align: align_of::<Contour>(),
    };
}

/// The capacities of a configuration: frame size and the [`crate::Recognizer`]'s const generics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capacities {
    /// Frame width, px.
    pub width: usize,
    /// Frame height, px.
    pub height: usize,
    /// `T`, templates in the library.
    pub templates: usize,
    /// `M`, points of a template (≥ `m`).
    pub template_points: usize,
    /// `P`, border points stored per frame.
    pub border_points: usize,
    /// `C`, borders kept per frame.
    pub contours: usize,
    /// `D`, DP table cells (≥ `n·(m − n + 1)`).
    pub dp_cells: usize,
}

impl Capacities {
    /// The smallest capacities for `n` part points and `m` template points: `M = m`,
    /// `D = n·(m − n + 1)`.
    pub const fn for_points(
        width: usize,
        height: usize,
        n: usize,
        m: usize,
        templates: usize,
        border_points: usize,
        contours: usize,
    ) -> Self {
        Capacities {
            width,
            height,
            templates,
            template_points: m,
            border_points,
            contours,
            dp_cells: table_cells(n, m),
        }
    }
}

/// The bytes of every static buffer of a configuration (see the module's table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    /// Background model plane, `w·h`.
    pub background: usize,
    /// Label plane (mask and border labels; high byte of the sum while learning), `w·h`.
    pub labels: usize,
    /// Contour store points, `4·P`.
    pub contour_points: usize,
    /// Contour store records and counters.
    pub contour_records: usize,
    /// The template library held by the recognizer.
    pub templates: usize,
    /// DP table, `4·D`.
    pub dp_table: usize,
    /// Resampled points, descriptor, correspondence and sub-pixel edge of the part being
    /// matched, `22·M`, and the mirror image of one template ([`part_buffer_bytes`]).
    pub part_buffers: usize,
    /// Parameters and alignment padding of the recognizer.
    pub other: usize,
    /// The whole recognizer, `size_of::<Recognizer<T, M, P, C, D>>()`.
    pub recognizer: usize,
    /// Static RAM of vorl: the two planes and the recognizer.
    pub total: usize,
    /// A frame buffer, `w·h` (not in [`Self::total`]: in flash in the firmware example, the
    /// sensor's DMA buffer on a camera).
    pub frame: usize,
}

const fn round_up(x: usize, align: usize) -> usize {
    if align <= 1 {
        return x;
    }
    x.saturating_add(align - 1) / align * align
}

const fn max(a: usize, b: usize) -> usize {
    if a > b {
        a
    } else {
        b
    }
}

/// `size_of::<heapless::Vec<X, cap>>()` for elements of `size` bytes aligned to `align`: the
/// length word, then the elements.
const fn vec_bytes(layout: Layout, size: usize, align: usize, cap: usize) -> usize {
    let align = max(align, layout.word);
    round_up(
        round_up(layout.word, align).saturating_add(size.saturating_mul(cap)),
        align,
    )
}

/// `size_of::<Template<M>>()`: `m` (a word); `8·M` points, `4·M` descriptor, `4·M` sorted
/// descriptor, `8·M` sub-pixel
/// edge points and `8·M` normals; centroid (8), area centroid (8), area (4) and position offset
/// (8), half-turn distance (4), near turn (16: turn, gap, score, whether the holes repeat, the
/// flag padded to 4), mirror gap and score (8), holes and tolerance (12); rounded up to the word.
pub const fn template_bytes(layout: Layout, m: usize) -> usize {
    round_up(
        layout
            .word
            .saturating_add(m.saturating_mul(32))
            .saturating_add(56 + HOLES_BYTES + 12),
        max(layout.word, 4),
    )
}

/// `size_of::<Holes>()`: [`crate::pose::holes::MAX_HOLES`] holes of 12 bytes and a `u32` count.
pub const HOLES_BYTES: usize = 12 * crate::pose::holes::MAX_HOLES + 4;

/// `size_of::<ContourStore<P, C>>()`: `4·P` points, the vector of `C` records and a counter.
pub const fn contour_store_bytes(layout: Layout, p: usize, c: usize) -> usize {
    let records = vec_bytes(layout, layout.contour, layout.contour_align, c);
    round_up(
        records.saturating_add(layout.word).saturating_add(p.saturating_mul(4)),
        max(layout.contour_align, layout.word),
    )
}

/// `size_of::<Recognizer<T, M, P, C, D>>()`.
pub const fn recognizer_bytes(layout: Layout, t: usize, m: usize, p: usize, c: usize, d: usize) -> usize {
    let templates = vec_bytes(layout, template_bytes(layout, m), max(layout.word, 4), t);
    let sum = layout
        .params
        .saturating_add(templates)
        .saturating_add(contour_store_bytes(layout, p, c))
        .saturating_add(part_buffer_bytes(layout, m))
        // Which template the mirror image is of (`Option<u16>`), whether the partial search
        // leaves blobs without a junction whole (`bool`), and the part's edge blur once
        // measured (`Option<Option<f32>>`, 8).
        .saturating_add(5 + 8)
        .saturating_add(d.saturating_mul(4));
    round_up(sum, max(layout.contour_align, layout.word))
}

/// Bytes per template point `M` of the part being matched: resampled points (8), descriptor (4),
/// correspondence (2) and sub-pixel edge points (8).
pub const PART_BYTES_PER_POINT: usize = 22;

/// The buffers of the part being matched: [`PART_BYTES_PER_POINT`] per template point, and
/// one template more, the mirror image of a chiral template that a part upside down is
/// matched against ([`crate::Template::mirrored`]); and the partial search's
/// ([`split_buffer_bytes`]).
pub const fn part_buffer_bytes(layout: Layout, m: usize) -> usize {
    m.saturating_mul(PART_BYTES_PER_POINT)
        .saturating_add(template_bytes(layout, m))
        .saturating_add(split_buffer_bytes(m))
}

/// The partial search's buffers ([`crate::recognizer::split`]): the blob's border at a template's step and
/// its turning angles, 12 bytes for each of [`crate::recognizer::split::BLOB_POINTS`]; a template's
/// turning angles and the open DP's rows, `4·M·(ARC_ROWS + 2)`.
pub const fn split_buffer_bytes(m: usize) -> usize {
    (12 * crate::recognizer::split::BLOB_POINTS)
        .saturating_add(m.saturating_mul(4 * (crate::shape::arcs::ARC_ROWS + 2)))
}

/// The budget of a configuration on a target.
pub const fn budget(layout: Layout, caps: Capacities) -> Budget {
    let plane = caps.width.saturating_mul(caps.height);
    let recognizer = recognizer_bytes(
        layout,
        caps.templates,
        caps.template_points,
        caps.border_points,
        caps.contours,
        caps.dp_cells,
    );
    let contour_points = caps.border_points.saturating_mul(4);
    let contour_records = contour_store_bytes(layout, caps.border_points, caps.contours).saturating_sub(contour_points);
    let templates = vec_bytes(
        layout,
        template_bytes(layout, caps.template_points),
        max(layout.word, 4),
        caps.templates,
    );
    let dp_table = caps.dp_cells.saturating_mul(4);
    let part_buffers = part_buffer_bytes(layout, caps.template_points);
    let listed = contour_points
        .saturating_add(contour_records)
        .saturating_add(templates)
        .saturating_add(dp_table)
        .saturating_add(part_buffers);
    Budget {
        background: plane,
        labels: plane,
        contour_points,
        contour_records,
        templates,
        dp_table,
        part_buffers,
        other: recognizer.saturating_sub(listed),
        recognizer,
        total: plane.saturating_mul(2).saturating_add(recognizer),
        frame: plane,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::borders::contour::ContourStore;
    use crate::library::template::Template;
    use crate::recognizer::Recognizer;

    macro_rules! check_recognizer {
        ($t:expr, $m:expr, $p:expr, $c:expr, $d:expr) => {
            assert_eq!(
                recognizer_bytes(Layout::NATIVE, $t, $m, $p, $c, $d),
                size_of::<Recognizer<$t, $m, $p, $c, $d>>(),
                "Recognizer<{}, {}, {}, {}, {}>",
                $t,
                $m,
                $p,
                $c,
                $d
            );
        };
    }

    #[test]
    fn template_formula_equals_size_of() {
        assert_eq!(template_bytes(Layout::NATIVE, 1), size_of::<Template<1>>());
        assert_eq!(template_bytes(Layout::NATIVE, 48), size_of::<Template<48>>());
        assert_eq!(template_bytes(Layout::NATIVE, 96), size_of::<Template<96>>());
        assert_eq!(template_bytes(Layout::NATIVE, 97), size_of::<Template<97>>());
        assert_eq!(template_bytes(Layout::NATIVE, 384), size_of::<Template<384>>());
    }

    #[test]
    fn contour_store_formula_equals_size_of() {
        assert_eq!(
            contour_store_bytes(Layout::NATIVE, 4096, 64),
            size_of::<ContourStore<4096, 64>>()
        );
        assert_eq!(
            contour_store_bytes(Layout::NATIVE, 1, 1),
            size_of::<ContourStore<1, 1>>()
        );
        assert_eq!(
            contour_store_bytes(Layout::NATIVE, 2047, 33),
            size_of::<ContourStore<2047, 33>>()
        );
    }

    #[test]
    fn recognizer_formula_equals_size_of() {
        check_recognizer!(8, 96, 4096, 64, 2112);
        check_recognizer!(8, 96, 4096, 64, 2176);
        check_recognizer!(4, 48, 2048, 32, 544);
        check_recognizer!(16, 192, 8192, 128, 8256);
        check_recognizer!(3, 97, 1001, 7, 33);
        check_recognizer!(1, 1, 1, 1, 1);
        check_recognizer!(0, 5, 3, 0, 0);
    }

    #[test]
    fn native_layout_is_size_of() {
        assert_eq!(Layout::NATIVE.params, size_of::<Params>());
        assert_eq!(Layout::NATIVE.contour, size_of::<Contour>());
        if size_of::<usize>() == 4 {
            assert_eq!(
                Layout::NATIVE,
                Layout {
                    name: "native",
                    ..Layout::CORTEX_M
                }
            );
        }
    }

    #[test]
    fn budget_adds_up() {
        let caps = Capacities::for_points(320, 240, 64, 96, 8, 4096, 64);
        assert_eq!(caps.dp_cells, 2112);
        for layout in [Layout::NATIVE, Layout::CORTEX_M] {
            let b = budget(layout, caps);
            let parts = b.contour_points + b.contour_records + b.templates + b.dp_table + b.part_buffers + b.other;
            assert_eq!(parts, b.recognizer);
            assert_eq!(b.total, b.background + b.labels + b.recognizer);
            assert_eq!(b.frame, 76_800);
            let fixed = layout.params;
            // The parameters, 13 bytes of small fields (the mirror's template, the junction
            // gate, the part's edge blur) and the rounding to the alignment.
            assert!(b.other >= fixed + 13 && b.other < fixed + 13 + 8, "{}", b.other - fixed);
        }
        // 32-bit: 8 templates of (4 + 32·96 + 56 + 100 for the holes + 12 for the tolerance)
        // bytes and the length word.
        assert_eq!(budget(Layout::CORTEX_M, caps).templates, 4 + 8 * 3244);
        // The part buffers: 22 bytes per point and one template, the mirror image; the partial
        // search's 512 border points (8 + 4 bytes) and 15 rows of 96 cells.
        assert_eq!(
            budget(Layout::CORTEX_M, caps).part_buffers,
            22 * 96 + 3244 + 512 * 12 + 15 * 96 * 4
        );
    }

    #[test]
    fn huge_capacities_saturate_instead_of_overflowing() {
        let caps = Capacities {
            width: usize::MAX,
            height: 3,
            templates: usize::MAX,
            template_points: usize::MAX,
            border_points: usize::MAX,
            contours: usize::MAX,
            dp_cells: usize::MAX,
        };
        let b = budget(Layout::CORTEX_M, caps);
        assert!(b.total >= b.recognizer);
    }
}
