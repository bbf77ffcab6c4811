//! `vorl budget`: the RAM a configuration needs on the camera, before anything is built.
//!
//! Every figure comes from the core's own budget calculator (`vorl_core::budget`), which mirrors
//! the layouts of the recognizer's buffers and is held equal to `size_of` by its tests and, on
//! the MCU, by the firmware example at compile time; the firmware's linker figure
//! (`.data + .bss`) is compared with this command's total by the firmware test.

use std::process::ExitCode;

use vorl_core::borders::resample::check_counts;
use vorl_core::budget::{budget, Budget, Capacities, Layout};

/// Part point counts of the table printed when `--points` is not given.
pub const SWEEP_POINTS: [usize; 6] = [32, 64, 96, 128, 192, 256];
/// Template counts of `--sweep`.
pub const SWEEP_TEMPLATES: [usize; 3] = [4, 8, 16];
/// Frame sizes of `--sweep`: QQVGA, QVGA, VGA.
pub const SWEEP_FRAMES: [(&str, usize, usize); 3] = [("QQVGA", 160, 120), ("QVGA", 320, 240), ("VGA", 640, 480)];
/// RAM sizes the fit columns are judged against.
pub const RAM_SIZES: [(&str, usize); 4] = [
    ("64K", 64 << 10),
    ("256K", 256 << 10),
    ("512K", 512 << 10),
    ("1M", 1 << 20),
];
/// Stack reserved above the static buffers when judging a fit (`_vorl_min_stack` in `memory.x`).
pub const STACK_RESERVE: usize = 24 << 10;

/// The target whose struct layouts the budget uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Target {
    /// 32-bit Arm Cortex-M (the camera).
    CortexM,
    /// The machine running `vorl` (for the host simulator's own use).
    Native,
}

impl Target {
    /// The core's layout for this target.
    pub fn layout(self) -> Layout {
        match self {
            Target::CortexM => Layout::CORTEX_M,
            Target::Native => Layout::NATIVE,
        }
    }
}

/// Arguments of `vorl budget`.
#[derive(Debug, Clone, clap::Args)]
#[command(
    after_help = "Static RAM = background plane + label plane + the recognizer (templates, \
    contour store, DP table, part buffers): what the firmware's linker reports as .data + .bss. \
    The frame buffer (flash in the firmware example, the sensor's DMA buffer on a camera) and the \
    stack are listed apart. Without --points, a table over n = 32, 64, 96, 128, 192, 256 \
    (m = round(1.5·n)).\n\n\
    Examples:\n  \
    vorl budget\n  \
    vorl budget --width 320 --height 240 --points 64 --template-points 96 --templates 8 --max-contours 64\n  \
    vorl budget --width 640 --height 480 --templates 16 --markdown\n  \
    vorl budget --sweep --markdown > table.md\n  \
    vorl budget --points 64 --json"
)]
pub struct BudgetArgs {
    /// Frame width, px.
    #[arg(long, default_value_t = 320)]
    pub width: usize,
    /// Frame height, px.
    #[arg(long, default_value_t = 240)]
    pub height: usize,
    /// Points per part contour, n (default: a table over several n).
    #[arg(long, value_name = "N")]
    pub points: Option<usize>,
    /// Points per template contour, m (n ≤ m < 2n; default round(1.5·n)).
    #[arg(long, value_name = "M")]
    pub template_points: Option<usize>,
    /// Templates in the library, T.
    #[arg(long, value_name = "T", default_value_t = 8)]
    pub templates: usize,
    /// Borders kept per frame, C.
    #[arg(long, value_name = "C", default_value_t = 64)]
    pub max_contours: usize,
    /// Border points stored per frame, P (default 4096·(w + h)/560: 4096 for QVGA).
    #[arg(long, value_name = "P")]
    pub border_points: Option<usize>,
    /// DP table cells, D (default n·(m − n + 1), the least that works).
    #[arg(long, value_name = "D")]
    pub dp_cells: Option<usize>,
    /// Struct layouts of this target.
    #[arg(long, value_enum, default_value_t = Target::CortexM)]
    pub target: Target,
    /// The table of docs/memory-budget.md: QQVGA, QVGA, VGA × n × 4/8/16 templates.
    #[arg(long, conflicts_with_all = ["points", "template_points", "width", "height", "templates"])]
    pub sweep: bool,
    /// Print tables as Markdown.
    #[arg(long)]
    pub markdown: bool,
    /// Print JSON.
    #[arg(long, conflicts_with = "markdown")]
    pub json: bool,
}

/// One configuration and its budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Row {
    /// Frame name (QVGA, …) when it has one.
    pub frame: Option<&'static str>,
    /// Part points n.
    pub n: usize,
    /// Template points m.
    pub m: usize,
    /// The capacities.
    pub caps: Capacities,
    /// The bytes.
    pub budget: Budget,
}

impl Row {
    /// The smallest of [`RAM_SIZES`] holding `bytes` plus [`STACK_RESERVE`].
    pub fn smallest_ram(bytes: usize) -> Option<&'static str> {
        RAM_SIZES
            .iter()
            .find(|(_, size)| bytes + STACK_RESERVE <= *size)
            .map(|(name, _)| *name)
    }
}

/// Default template points for `n`: `round(1.5·n)` (the firmware's 64 → 96).
pub fn default_m(n: usize) -> usize {
    (3 * n).div_ceil(2)
}

/// Default border point capacity for a frame: `4096·(w + h)/560` rounded up to 256 (4096 for QVGA,
/// 2048 for QQVGA, 8192 for VGA): borders grow with the frame's side, not its area.
pub fn default_border_points(width: usize, height: usize) -> usize {
    (4096 * (width + height)).div_ceil(560).div_ceil(256) * 256
}

fn row(
    args: &BudgetArgs,
    frame: Option<&'static str>,
    w: usize,
    h: usize,
    n: usize,
    m: Option<usize>,
    t: usize,
) -> Result<Row, String> {
    let m = m.unwrap_or_else(|| default_m(n));
    check_counts(n, m).map_err(|e| format!("--points {n} --template-points {m}: {e}"))?;
    if w == 0 || h == 0 {
        return Err(format!("frame {w}×{h}: width and height must be at least 1"));
    }
    let p = args.border_points.unwrap_or_else(|| default_border_points(w, h));
    let mut caps = Capacities::for_points(w, h, n, m, t, p, args.max_contours);
    if let Some(d) = args.dp_cells {
        if d < caps.dp_cells {
            return Err(format!(
                "--dp-cells {d}: n = {n}, m = {m} need at least n·(m − n + 1) = {}",
                caps.dp_cells
            ));
        }
        caps.dp_cells = d;
    }
    Ok(Row {
        frame,
        n,
        m,
        caps,
        budget: budget(args.target.layout(), caps),
    })
}

/// The configurations the arguments ask for, with their budgets.
///
/// # Errors
/// Point counts that break `n ≤ m < 2n`, an empty frame, or `--dp-cells` below `n·(m − n + 1)`.
pub fn rows(args: &BudgetArgs) -> Result<Vec<Row>, String> {
    if args.sweep {
        let mut out = Vec::new();
        for (name, w, h) in SWEEP_FRAMES {
            for n in SWEEP_POINTS {
                for t in SWEEP_TEMPLATES {
                    out.push(row(args, Some(name), w, h, n, None, t)?);
                }
            }
        }
        return Ok(out);
    }
    let frame = SWEEP_FRAMES
        .iter()
        .find(|(_, w, h)| (*w, *h) == (args.width, args.height))
        .map(|f| f.0);
    match args.points {
        Some(n) => Ok(vec![row(
            args,
            frame,
            args.width,
            args.height,
            n,
            args.template_points,
            args.templates,
        )?]),
        None => SWEEP_POINTS
            .iter()
            .map(|&n| row(args, frame, args.width, args.height, n, None, args.templates))
            .collect(),
    }
}

/// Runs `vorl budget`.
///
/// # Errors
/// As [`rows`].
pub fn run(args: BudgetArgs) -> Result<ExitCode, String> {
    let rows = rows(&args)?;
    if args.json {
        let list: Vec<serde_json::Value> = rows.iter().map(|r| to_json(r, args.target)).collect();
        let value = if list.len() == 1 {
            list.into_iter().next().unwrap_or_default()
        } else {
            list.into()
        };
        println!("{}", serde_json::to_string_pretty(&value).map_err(|e| e.to_string())?);
    } else if rows.len() == 1 && !args.sweep {
        print_detail(&rows[0], args.target.layout());
    } else {
        print_table(&rows, &args);
    }
    Ok(ExitCode::SUCCESS)
}

/// The JSON of one row.
pub fn to_json(r: &Row, target: Target) -> serde_json::Value {
    let (c, b) = (&r.caps, &r.budget);
    serde_json::json!({
        "target": target.layout().name,
        "width": c.width, "height": c.height, "n": r.n, "m": r.m,
        "templates": c.templates, "template_points": c.template_points,
        "border_points": c.border_points, "contours": c.contours, "dp_cells": c.dp_cells,
        "bytes": {
            "background": b.background, "labels": b.labels,
            "contour_points": b.contour_points, "contour_records": b.contour_records,
            "templates": b.templates, "dp_table": b.dp_table, "part_buffers": b.part_buffers,
            "other": b.other, "recognizer": b.recognizer, "total": b.total,
            "frame": b.frame, "stack_reserve": STACK_RESERVE,
        },
        "fits": Row::smallest_ram(b.total),
        "fits_with_frame": Row::smallest_ram(b.total + b.frame),
    })
}

fn kib(bytes: usize) -> String {
    format!("{:.1}", bytes as f64 / 1024.0)
}

fn print_detail(r: &Row, layout: Layout) {
    let (c, b) = (&r.caps, &r.budget);
    println!(
        "vorl budget: {}×{} frames{}, n = {}, m = {}, T = {} templates, P = {} border points, C = {} borders, D = {} DP cells; {} layout",
        c.width,
        c.height,
        r.frame.map(|f| format!(" ({f})")).unwrap_or_default(),
        r.n,
        r.m,
        c.templates,
        c.border_points,
        c.contours,
        c.dp_cells,
        layout.name
    );
    println!();
    let tpl = vorl_core::budget::template_bytes(layout, c.template_points);
    let lines: [(&str, usize, String); 9] = [
        ("background plane", b.background, "w·h".into()),
        ("label plane", b.labels, "w·h".into()),
        ("contour points", b.contour_points, "4·P".into()),
        (
            "contour records",
            b.contour_records,
            format!("C·{} + counters", layout.contour),
        ),
        (
            "templates",
            b.templates,
            format!("T·{tpl} + length word ({tpl} = {} + 32·M + 32)", layout.word),
        ),
        ("DP table", b.dp_table, "4·D".into()),
        (
            "part buffers",
            b.part_buffers,
            "22·M (points 8·M, descriptor 4·M, pairs 2·M, part edge 8·M)".into(),
        ),
        ("params", b.other, format!("Params {} bytes, alignment", layout.params)),
        (
            "total static RAM",
            b.total,
            "planes + recognizer: the firmware's .data + .bss".into(),
        ),
    ];
    println!("{:<22} {:>10} {:>9}  formula", "buffer", "bytes", "KiB");
    // Without an empty shot the platform is estimated per frame into the background plane,
    // with a grid of cells beside it (not in the total: only installations without an empty
    // shot need it).
    let cells = vorl_core::pixels::platform::cell_size(c.width, c.height, usize::MAX)
        .map(|s| c.width.div_ceil(s) * c.height.div_ceil(s))
        .unwrap_or(0);
    let grid = 9 * cells;
    for (name, bytes, formula) in lines.into_iter().chain([(
        "+ platform grid",
        grid,
        format!("9·G, G = {cells} cells of 16 px (only without an empty shot; not in the total)"),
    )]) {
        println!("{name:<22} {bytes:>10} {:>9}  {formula}", kib(bytes));
    }
    println!();
    println!(
        "{:<22} {:>10} {:>9}  w·h, not in the total (flash in the firmware example, the sensor's DMA buffer on a camera)",
        "frame buffer",
        b.frame,
        kib(b.frame)
    );
    println!(
        "{:<22} {:>10} {:>9}  reserve above the static buffers (memory.x), not in the total",
        "stack",
        STACK_RESERVE,
        kib(STACK_RESERVE)
    );
    println!();
    let fit = |bytes: usize| Row::smallest_ram(bytes).map_or("more than 1M".to_string(), |s| format!("{s} of RAM"));
    println!("fits (static + stack):                {}", fit(b.total));
    println!("fits (static + frame buffer + stack): {}", fit(b.total + b.frame));
}

fn print_table(rows: &[Row], args: &BudgetArgs) {
    let header = [
        "frame",
        "n",
        "m",
        "T",
        "P",
        "C",
        "D",
        "planes",
        "contours",
        "templates",
        "DP table",
        "part+other",
        "static RAM",
        "+ frame",
        "fits",
        "fits + frame",
    ];
    let cells = |r: &Row| -> Vec<String> {
        let (c, b) = (&r.caps, &r.budget);
        let fit = |bytes: usize| Row::smallest_ram(bytes).unwrap_or("—").to_string();
        vec![
            r.frame.map_or_else(
                || format!("{}×{}", c.width, c.height),
                |f| format!("{f} {}×{}", c.width, c.height),
            ),
            r.n.to_string(),
            r.m.to_string(),
            c.templates.to_string(),
            c.border_points.to_string(),
            c.contours.to_string(),
            c.dp_cells.to_string(),
            (b.background + b.labels).to_string(),
            (b.contour_points + b.contour_records).to_string(),
            b.templates.to_string(),
            b.dp_table.to_string(),
            (b.part_buffers + b.other).to_string(),
            b.total.to_string(),
            (b.total + b.frame).to_string(),
            fit(b.total),
            fit(b.total + b.frame),
        ]
    };
    let body: Vec<Vec<String>> = rows.iter().map(cells).collect();
    if args.markdown {
        println!("| {} |", header.join(" | "));
        let align: Vec<&str> = header
            .iter()
            .enumerate()
            .map(|(i, _)| if i == 0 || i >= 14 { "---" } else { "---:" })
            .collect();
        println!("| {} |", align.join(" | "));
        for line in &body {
            println!("| {} |", line.join(" | "));
        }
    } else {
        let widths: Vec<usize> = (0..header.len())
            .map(|i| {
                body.iter()
                    .map(|l| l[i].chars().count())
                    .chain([header[i].chars().count()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let fmt_line = |cols: Vec<String>| -> String {
            cols.iter()
                .enumerate()
                .map(|(i, c)| {
                    if i == 0 {
                        format!("{c:<w$}", w = widths[i])
                    } else {
                        format!("{c:>w$}", w = widths[i])
                    }
                })
                .collect::<Vec<_>>()
                .join("  ")
        };
        println!("{}", fmt_line(header.iter().map(|s| s.to_string()).collect()));
        for line in body {
            println!("{}", fmt_line(line));
        }
    }
    println!();
    println!(
        "Bytes, {} layout. static RAM = planes (2·w·h) + recognizer; \"+ frame\" adds one w·h frame buffer. \
         fits = the smallest of 64K/256K/512K/1M of RAM holding it and a {} KiB stack (— = none).",
        args.target.layout().name,
        STACK_RESERVE >> 10
    );
}
