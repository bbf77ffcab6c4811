//! Plots for `docs/performance.md` from criterion's results.
//!
//! ```sh
//! cargo bench -p vorl-core --bench dp
//! cargo bench -p vorl-core --bench pipeline -- frame
//! cargo run --release -p vorl-host-sim --example perf_plot [CRITERION_DIR [OUT_DIR]]
//! ```
//!
//! or all three at once with short measurement times: `bash scripts/perf.sh`.
//!
//! Reads the median point estimate (`median.point_estimate`, nanoseconds) from
//! `CRITERION_DIR/<group>/<function>/[<parameter>/]new/estimates.json` and writes two SVGs into
//! `OUT_DIR`:
//!
//! - `perf_dp.svg`: group `cyclic_dp` of `core/benches/dp.rs`, time of one match (optimum over
//!   every start and the correspondence) against the part's point count n (m = 1.5·n, plus the
//!   paper's 76 × 133), one line for the core and one for the std reference, log-scale time axis,
//!   the reference/core ratio written at each reference point;
//! - `perf_frame.svg`: group `frame` of `core/benches/pipeline.rs`, time of one 640×480 frame
//!   against the number of templates (4, 12, 32), one line per number of parts (1, 4, 8).
//!
//! `CRITERION_DIR` defaults to `$CARGO_TARGET_DIR/criterion` when that variable is set, else to
//! the workspace's `target/criterion`; `OUT_DIR` defaults to the workspace's `docs/images`
//! (both independent of the current directory). Arguments given are taken relative to the
//! current directory. The medians are also printed as a table.
//!
//! A missing or unreadable result is reported with its path and the command that produces it;
//! the exit code is then 1 and no SVG is written. Uses plotters' SVG backend only: text becomes
//! SVG `<text>` elements, no system font library is needed.

use plotters::coord::combinators::IntoPartialAxis;
use plotters::coord::ranged1d::{DefaultFormatting, Ranged};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// (n, m) of group `cyclic_dp`, as in `core/benches/dp.rs`.
const DP_SIZES: [(usize, usize); 5] = [(32, 48), (64, 96), (76, 133), (128, 192), (256, 384)];
/// Functions of group `cyclic_dp`: id and legend label.
const DP_SIDES: [(&str, &str); 2] = [
    ("core", "core (f32, divide and conquer)"),
    ("reference", "reference (f64, textbook loop)"),
];
/// Parts and templates of group `frame`, as in `core/benches/pipeline.rs`.
const FRAME_PARTS: [usize; 3] = [1, 4, 8];
const FRAME_TEMPLATES: [usize; 3] = [4, 12, 32];

const DP_BENCH: &str = "cargo bench -p vorl-core --bench dp";
const FRAME_BENCH: &str = "cargo bench -p vorl-core --bench pipeline -- frame";

const WIDTH: u32 = 800;
const HEIGHT: u32 = 520;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("perf_plot: error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn workspace_root() -> PathBuf {
    // host-sim/ is one level below the workspace root.
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn run() -> Result<(), String> {
    let mut args = std::env::args_os().skip(1);
    let first = args.next();
    if first.as_deref().is_some_and(|a| a == "-h" || a == "--help") {
        println!("usage: perf_plot [CRITERION_DIR [OUT_DIR]]");
        println!("  CRITERION_DIR  criterion's output (default: the workspace's target/criterion)");
        println!("  OUT_DIR        where perf_dp.svg and perf_frame.svg go (default: docs/images)");
        return Ok(());
    }
    let criterion = match first {
        Some(dir) => PathBuf::from(dir),
        None => match std::env::var_os("CARGO_TARGET_DIR") {
            Some(target) if !target.is_empty() => PathBuf::from(target).join("criterion"),
            _ => workspace_root().join("target").join("criterion"),
        },
    };
    let out = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("docs").join("images"));
    if let Some(extra) = args.next() {
        return Err(format!(
            "unexpected argument {:?}; usage: perf_plot [CRITERION_DIR [OUT_DIR]]",
            extra
        ));
    }
    if !criterion.is_dir() {
        return Err(format!(
            "no criterion results at {}: run `{DP_BENCH}` and `{FRAME_BENCH}` first \
             (or `bash scripts/perf.sh`), or pass the criterion folder as the first argument",
            criterion.display()
        ));
    }

    // Read everything first, so that every missing file is reported at once.
    let mut problems = Vec::new();
    let dp = read_dp(&criterion, &mut problems);
    let frame = read_frame(&criterion, &mut problems);
    if !problems.is_empty() {
        let mut message = format!("{} benchmark result(s) missing or unreadable:", problems.len());
        for p in &problems {
            let _ = write!(message, "\n  {p}");
        }
        message.push_str("\n(`bash scripts/perf.sh` runs both benches and this plot)");
        return Err(message);
    }
    let (Some(dp), Some(frame)) = (dp, frame) else {
        return Err("internal: results incomplete without a reported problem".into());
    };

    print_tables(&dp, &frame);

    std::fs::create_dir_all(&out).map_err(|e| format!("cannot create output folder {}: {e}", out.display()))?;
    let dp_svg = out.join("perf_dp.svg");
    plot_dp(&dp, &dp_svg).map_err(|e| format!("cannot draw {}: {e}", dp_svg.display()))?;
    let frame_svg = out.join("perf_frame.svg");
    plot_frame(&frame, &frame_svg).map_err(|e| format!("cannot draw {}: {e}", frame_svg.display()))?;
    println!("wrote {}", dp_svg.display());
    println!("wrote {}", frame_svg.display());
    Ok(())
}

/// The median point estimate in nanoseconds of `<criterion>/<id>/new/estimates.json`.
fn median_ns(criterion: &Path, id: &str, bench: &str) -> Result<f64, String> {
    let path = criterion.join(id).join("new").join("estimates.json");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            format!("{} not found; run `{bench}` to produce it", path.display())
        } else {
            format!("{}: {e}", path.display())
        }
    })?;
    let json: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: not JSON ({e}); rerun `{bench}`", path.display()))?;
    let value = json
        .pointer("/median/point_estimate")
        .and_then(serde_json::Value::as_f64)
        .ok_or_else(|| format!("{}: no median.point_estimate; rerun `{bench}`", path.display()))?;
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(format!(
            "{}: median {value} ns is not a positive time; rerun `{bench}`",
            path.display()
        ))
    }
}

/// Medians in nanoseconds: `[size][side]`, sides in the order of [`DP_SIDES`].
type DpTimes = Vec<[f64; 2]>;
/// Medians in nanoseconds: `[parts][templates]`, in the order of the constants.
type FrameTimes = [[f64; 3]; 3];

fn read_dp(criterion: &Path, problems: &mut Vec<String>) -> Option<DpTimes> {
    let mut times = Vec::new();
    let mut complete = true;
    for (n, m) in DP_SIZES {
        let mut row = [0.0; 2];
        for (slot, (side, _)) in row.iter_mut().zip(DP_SIDES) {
            match median_ns(criterion, &format!("cyclic_dp/{side}/{n}x{m}"), DP_BENCH) {
                Ok(v) => *slot = v,
                Err(e) => {
                    problems.push(e);
                    complete = false;
                }
            }
        }
        times.push(row);
    }
    complete.then_some(times)
}

fn read_frame(criterion: &Path, problems: &mut Vec<String>) -> Option<FrameTimes> {
    let mut times = [[0.0; 3]; 3];
    let mut complete = true;
    for (row, parts) in times.iter_mut().zip(FRAME_PARTS) {
        for (slot, templates) in row.iter_mut().zip(FRAME_TEMPLATES) {
            match median_ns(
                criterion,
                &format!("frame/{parts}_parts_{templates}_templates"),
                FRAME_BENCH,
            ) {
                Ok(v) => *slot = v,
                Err(e) => {
                    problems.push(e);
                    complete = false;
                }
            }
        }
    }
    complete.then_some(times)
}

/// A time in nanoseconds as a value in ms, µs or ns, whichever keeps it at 1 or more.
fn scaled(ns: f64) -> (f64, &'static str) {
    if ns >= 1e6 {
        (ns / 1e6, "ms")
    } else if ns >= 1e3 {
        (ns / 1e3, "µs")
    } else {
        (ns, "ns")
    }
}

/// A time in nanoseconds with a unit that keeps 2–3 significant digits.
fn human(ns: f64) -> String {
    let (value, unit) = scaled(ns);
    if value >= 100.0 {
        format!("{value:.0} {unit}")
    } else if value >= 10.0 {
        format!("{value:.1} {unit}")
    } else {
        format!("{value:.2} {unit}")
    }
}

/// An axis label: a time in nanoseconds with a unit, no trailing zeros ("1 ms", "250 µs").
fn tick(ns: f64) -> String {
    let (value, unit) = scaled(ns);
    let text = format!("{value:.2}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text} {unit}")
}

fn print_tables(dp: &DpTimes, frame: &FrameTimes) {
    println!("cyclic_dp (median)");
    println!("  {:>9}  {:>10}  {:>10}  {:>6}", "n x m", "core", "reference", "ratio");
    for ((n, m), [core, reference]) in DP_SIZES.iter().zip(dp) {
        println!(
            "  {:>9}  {:>10}  {:>10}  {:>5.0}x",
            format!("{n}x{m}"),
            human(*core),
            human(*reference),
            reference / core
        );
    }
    println!("frame (median, 640x480)");
    println!("  {:>15}  {:>9}  {:>9}  {:>9}", "parts\\templates", 4, 12, 32);
    for (parts, row) in FRAME_PARTS.iter().zip(frame) {
        println!(
            "  {:>15}  {:>9}  {:>9}  {:>9}",
            parts,
            human(row[0]),
            human(row[1]),
            human(row[2])
        );
    }
}

/// A linear axis over `range` with ticks and grid lines at `points` only. (`with_key_points` on
/// a plain `f64` range cannot take a label formatter in plotters 0.3.7; the whole-range
/// `partial_axis` around it can.)
fn key_axis(
    range: std::ops::Range<f64>,
    points: Vec<f64>,
) -> impl Ranged<ValueType = f64, FormatOption = DefaultFormatting> {
    range.clone().with_key_points(points).partial_axis(range)
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

fn plot_dp(dp: &DpTimes, path: &Path) -> DrawResult {
    // Time axis in µs, whole decades around the data.
    let us: Vec<[f64; 2]> = dp.iter().map(|r| [r[0] / 1e3, r[1] / 1e3]).collect();
    let lo = us.iter().flatten().copied().fold(f64::INFINITY, f64::min);
    let hi = us.iter().flatten().copied().fold(0.0, f64::max);
    let y0 = 10f64.powf(lo.log10().floor());
    let y1 = 10f64.powf(hi.log10().ceil());
    // Labelled lines at the decades, light lines at 2× and 5×.
    let decades: Vec<f64> = std::iter::successors(Some(y0), |v| Some(v * 10.0))
        .take_while(|v| *v <= y1 * 1.001)
        .collect();
    let light: Vec<f64> = decades
        .iter()
        .flat_map(|d| [2.0 * d, 5.0 * d])
        .filter(|v| *v < y1)
        .collect();
    let x1 = DP_SIZES.last().map_or(256, |s| s.0) as f64 * 1.08;
    let ns: Vec<f64> = DP_SIZES.iter().map(|s| s.0 as f64).collect();

    let root = SVGBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Cyclic DP: one match, core against reference (median)",
            ("sans-serif", 22),
        )
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(76)
        .build_cartesian_2d(
            key_axis(0.0..x1, ns),
            (y0..y1).log_scale().with_key_points(decades).with_light_points(light),
        )?;
    chart
        .configure_mesh()
        .x_desc("part points n (template points m = 1.5·n; n = 76, m = 133: the paper's sizes)")
        .y_desc("time per match (log scale)")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| tick(y * 1e3))
        .axis_desc_style(("sans-serif", 16))
        .label_style(("sans-serif", 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;

    let colours = [RGBColor(31, 119, 180), RGBColor(214, 39, 40)];
    for (side, ((_, label), colour)) in DP_SIDES.iter().zip(colours).enumerate() {
        let points: Vec<(f64, f64)> = DP_SIZES
            .iter()
            .zip(&us)
            .map(|((n, _), t)| (*n as f64, t[side]))
            .collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?
            .label(*label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(2)));
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
    }
    // The ratio above each reference point.
    let style = TextStyle::from(("sans-serif", 14).into_font())
        .color(&RGBColor(90, 90, 90))
        .pos(Pos::new(HPos::Center, VPos::Bottom));
    for ((n, _), t) in DP_SIZES.iter().zip(&us) {
        let at = chart.backend_coord(&(*n as f64, t[1]));
        root.draw(&Text::new(
            format!("{:.0}×", t[1] / t[0]),
            (at.0, at.1 - 8),
            style.clone(),
        ))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .margin(12)
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .draw()?;
    root.present()?;
    Ok(())
}

fn plot_frame(frame: &FrameTimes, path: &Path) -> DrawResult {
    let ms: Vec<[f64; 3]> = frame.iter().map(|r| r.map(|v| v / 1e6)).collect();
    let hi = ms.iter().flatten().copied().fold(0.0, f64::max);
    // Room above the data for the legend, in the upper corner whose column is lower.
    let column_max = |i: usize| ms.iter().map(|r| r[i]).fold(0.0, f64::max);
    let corner = if column_max(0) > column_max(2) {
        SeriesLabelPosition::UpperRight
    } else {
        SeriesLabelPosition::UpperLeft
    };
    let step = if hi * 1.3 > 20.0 { 10.0 } else { 5.0 };
    let y1 = (hi * 1.3 / step).ceil() * step;

    let root = SVGBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Whole pipeline: one 640×480 frame (median)", ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(64)
        .build_cartesian_2d(
            key_axis(0.0..36.0, FRAME_TEMPLATES.map(|t| t as f64).to_vec()),
            0f64..y1,
        )?;
    chart
        .configure_mesh()
        .x_desc("number of taught templates")
        .y_desc("time per frame (ms)")
        .y_labels(10)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y:.0}"))
        .axis_desc_style(("sans-serif", 16))
        .label_style(("sans-serif", 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;

    let colours = [RGBColor(44, 160, 44), RGBColor(255, 127, 14), RGBColor(148, 103, 189)];
    for ((parts, row), colour) in FRAME_PARTS.iter().zip(&ms).zip(colours) {
        let points: Vec<(f64, f64)> = FRAME_TEMPLATES.iter().zip(row).map(|(t, v)| (*t as f64, *v)).collect();
        let label = if *parts == 1 {
            "1 part".to_string()
        } else {
            format!("{parts} parts")
        };
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(2)));
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(corner)
        .margin(12)
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .draw()?;
    root.present()?;
    Ok(())
}
