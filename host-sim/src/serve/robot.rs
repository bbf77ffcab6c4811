//! The robot port: plain TCP, ASCII lines ending in `\n` (a `\r` before it is dropped).
//!
//! ```text
//! → TRG    detect on the next frame and answer with its result
//! → LAST   the result of the last frame processed
//! → PING
//! ← RES <frame> <n>   then n lines  <class> <x> <y> <angle_deg> <flipped> <score>
//! ← END
//! ← PONG
//! ← ERR <message>
//! ```
//!
//! Commands are taken in any case. `class` is `?` for an unknown part (spaces in a class name
//! become `_`); `flipped` is 0 or 1; numbers have 3 decimals (`nan` for a score the part never
//! got); `x`, `y` and `angle_deg` are the robot's under a calibration, else pixels and the
//! image's angle. A line longer than [`MAX_LINE`] bytes is answered `ERR` at once and the rest
//! of it skipped. Each client has its own task: one that disconnects mid-answer, or waits on
//! a trigger and goes away, harms nobody.

use std::sync::Arc;

use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::{TcpListener, TcpStream};

use super::{Published, ServeError, Shared};
use crate::truth::PartJson;

/// The longest line taken, in bytes, without its `\n`.
pub const MAX_LINE: usize = 256;

/// A request on the robot port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// `TRG`: the next frame's result.
    Trigger,
    /// `LAST`: the last frame's result.
    Last,
    /// `PING`.
    Ping,
}

/// Reads one request line (without its `\n`).
///
/// # Errors
/// The message of the `ERR` line: an empty line, bytes that are not ASCII, an unknown command.
pub fn parse(line: &[u8]) -> Result<Request, String> {
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let text = std::str::from_utf8(line)
        .ok()
        .filter(|t| t.is_ascii())
        .ok_or("not an ASCII line")?;
    let word = text.trim();
    if word.eq_ignore_ascii_case("TRG") {
        Ok(Request::Trigger)
    } else if word.eq_ignore_ascii_case("LAST") {
        Ok(Request::Last)
    } else if word.eq_ignore_ascii_case("PING") {
        Ok(Request::Ping)
    } else if word.is_empty() {
        Err("empty line (commands: TRG, LAST, PING)".into())
    } else {
        let shown: String = word.chars().take(32).collect();
        Err(format!("unknown command {shown:?} (commands: TRG, LAST, PING)"))
    }
}

/// The answer to `TRG` or `LAST`: `RES <frame> <n>`, n part lines, `END`; or `ERR <frame>:
/// <why>` for a frame that gave no result.
pub fn format_result(p: &Published) -> String {
    if let Some(e) = &p.error {
        return err_line(&format!("frame {}: {e}", p.frame));
    }
    let mut out = format!("RES {} {}\n", word(&p.frame), p.parts.len());
    for part in &p.parts {
        out += &part_line(part);
        out.push('\n');
    }
    out += "END\n";
    out
}

/// One part's line: `<class> <x> <y> <angle_deg> <flipped> <score>`.
pub fn part_line(part: &PartJson) -> String {
    let class = part.class.as_deref().map_or_else(|| "?".to_string(), word);
    let robot = part.extra.get("robot");
    let num = |k: &str| robot.and_then(|r| r.get(k)).and_then(|v| v.as_f64());
    let (x, y, angle) = match (num("x"), num("y")) {
        (Some(x), Some(y)) => (x, y, num("angle_deg").unwrap_or(part.angle_deg)),
        _ => (part.x, part.y, part.angle_deg),
    };
    format!(
        "{class} {} {} {} {} {}",
        fixed3(x),
        fixed3(y),
        fixed3(angle),
        u8::from(part.flipped == Some(true)),
        fixed3(part.score.unwrap_or(f64::NAN))
    )
}

fn fixed3(v: f64) -> String {
    if v.is_finite() {
        // No "-0.000".
        let s = format!("{v:.3}");
        if s == "-0.000" {
            "0.000".into()
        } else {
            s
        }
    } else {
        "nan".into()
    }
}

/// A name as one word of ASCII: whitespace and control characters become `_`, other
/// non-ASCII characters `?`.
fn word(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_whitespace() || c.is_control() {
                '_'
            } else if c.is_ascii() {
                c
            } else {
                '?'
            }
        })
        .collect()
}

fn err_line(message: &str) -> String {
    format!("ERR {}\n", message.replace(['\n', '\r'], " "))
}

/// Accepts robot clients until the worker has stopped, each on its own task.
pub async fn serve(listener: TcpListener, shared: Arc<Shared>) {
    let mut stopped = shared.stopped();
    let mut clients = tokio::task::JoinSet::new();
    loop {
        tokio::select! {
            accepted = listener.accept() => {
                if let Ok((stream, _)) = accepted {
                    clients.spawn(client(stream, shared.clone()));
                }
            }
            _ = stopped.wait_for(|s| *s) => break,
            Some(_) = clients.join_next(), if !clients.is_empty() => {}
        }
    }
    // The worker has ended: clients' pending triggers got "ERR stopping"; close the rest.
    clients.abort_all();
    while clients.join_next().await.is_some() {}
}

/// What one read gave.
enum Line {
    /// A whole line (without its `\n`).
    Whole,
    /// A line past [`MAX_LINE`]; `ended` when its `\n` was read, else the rest of it is to
    /// be skipped.
    TooLong {
        /// Whether the long line's `\n` was read.
        ended: bool,
    },
    /// The client closed.
    Closed,
}

/// Reads up to the next `\n` into `buf`, never holding more than [`MAX_LINE`] bytes. After
/// [`Line::TooLong`] the caller calls again with `skipping` set until a [`Line::Whole`] ends
/// the long line.
async fn read_line<R: tokio::io::AsyncRead + Unpin>(
    reader: &mut BufReader<R>,
    buf: &mut Vec<u8>,
    skipping: bool,
) -> std::io::Result<Line> {
    loop {
        let avail = reader.fill_buf().await?;
        if avail.is_empty() {
            return Ok(Line::Closed);
        }
        match avail.iter().position(|&b| b == b'\n') {
            Some(i) => {
                let fits = !skipping && buf.len() + i <= MAX_LINE;
                if fits {
                    buf.extend_from_slice(&avail[..i]);
                }
                reader.consume(i + 1);
                return Ok(if fits || skipping {
                    Line::Whole
                } else {
                    Line::TooLong { ended: true }
                });
            }
            None => {
                let n = avail.len();
                if !skipping {
                    buf.extend_from_slice(avail);
                }
                reader.consume(n);
                if !skipping && buf.len() > MAX_LINE {
                    return Ok(Line::TooLong { ended: false });
                }
            }
        }
    }
}

async fn client(stream: TcpStream, shared: Arc<Shared>) {
    let _ = stream.set_nodelay(true);
    let (read, mut write) = stream.into_split();
    let mut reader = BufReader::with_capacity(1024, read);
    let mut buf = Vec::with_capacity(MAX_LINE + 1);
    let mut skipping = false;
    loop {
        buf.clear();
        let line = match read_line(&mut reader, &mut buf, skipping).await {
            Ok(l) => l,
            Err(_) => return,
        };
        let answer = match line {
            Line::Closed => return,
            Line::Whole if skipping => {
                // The end of a long line already answered.
                skipping = false;
                continue;
            }
            Line::TooLong { ended } => {
                skipping = !ended;
                err_line(&format!("line longer than {MAX_LINE} bytes"))
            }
            Line::Whole => answer(&buf, &shared).await,
        };
        if write.write_all(answer.as_bytes()).await.is_err() {
            return;
        }
    }
}

async fn answer(line: &[u8], shared: &Shared) -> String {
    match parse(line) {
        Ok(Request::Ping) => "PONG\n".into(),
        Ok(Request::Last) => match shared.last() {
            Ok(p) => format_result(&p),
            Err(e) => err_line(&e.to_string()),
        },
        Ok(Request::Trigger) => match shared.trigger() {
            Ok(rx) => match rx.await {
                Ok(p) => format_result(&p),
                Err(_) => err_line(&ServeError::Stopping.to_string()),
            },
            Err(e) => err_line(&e.to_string()),
        },
        Err(m) => err_line(&m),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_parse_in_any_case_and_with_cr() {
        assert_eq!(parse(b"TRG"), Ok(Request::Trigger));
        assert_eq!(parse(b"trg\r"), Ok(Request::Trigger));
        assert_eq!(parse(b" Last "), Ok(Request::Last));
        assert_eq!(parse(b"PING"), Ok(Request::Ping));
        assert!(parse(b"").unwrap_err().contains("empty"));
        assert!(parse(b"FIRE").unwrap_err().contains("unknown command \"FIRE\""));
        assert!(parse(b"TR\xffG").unwrap_err().contains("ASCII"));
        assert!(parse("PÏNG".as_bytes()).is_err());
    }

    fn part(class: Option<&str>, x: f64, y: f64, a: f64, flipped: bool, score: Option<f64>) -> PartJson {
        PartJson {
            class: class.map(String::from),
            x,
            y,
            angle_deg: a,
            symmetry: None,
            score,
            partial: None,
            flipped: flipped.then_some(true),
            touching: None,
            extra: Default::default(),
        }
    }

    #[test]
    fn part_lines_are_fixed_three_decimals() {
        assert_eq!(
            part_line(&part(Some("washer"), 12.34567, 0.0004, 359.9996, false, Some(0.01234))),
            "washer 12.346 0.000 360.000 0 0.012"
        );
        assert_eq!(
            part_line(&part(None, -1.5, 2.0, 90.0, true, None)),
            "? -1.500 2.000 90.000 1 nan"
        );
        assert_eq!(
            part_line(&part(Some("odd name\t1"), 1.0, 1.0, 0.0, false, Some(0.0))),
            "odd_name_1 1.000 1.000 0.000 0 0.000"
        );
        // Under a calibration the robot's coordinates and angle are sent.
        let mut p = part(Some("rod"), 100.0, 200.0, 10.0, false, Some(0.02));
        p.extra.insert(
            "robot".into(),
            serde_json::json!({"x": -12.25, "y": 3.5, "angle_deg": 12.0}),
        );
        assert_eq!(part_line(&p), "rod -12.250 3.500 12.000 0 0.020");
    }
}
