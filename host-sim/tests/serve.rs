//! `vorl serve` end to end: the real binary on loopback (ephemeral ports, `--stop-after` so a
//! server never outlives its test), the robot port over real TCP and the page's API over real
//! HTTP. Expected values come from `vorl detect --json` on the same frame at test time.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{vorl, Scratch};
use serde_json::{json, Value};

/// The bundled example set (8 frames, an empty shot, 13 templates).
fn plant() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/plant")
}

/// A running `vorl serve`, stopped (SIGTERM, then killed) when dropped.
struct Server {
    child: Child,
    web: String,
    robot: String,
    token: Option<String>,
}

impl Server {
    fn start(args: &[&str]) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_vorl"))
            .arg("serve")
            .args(args)
            .args(["--http", "127.0.0.1:0", "--robot", "127.0.0.1:0", "--stop-after", "120"])
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start vorl serve");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            // Drained to the end, so that the server never blocks on a full pipe.
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        let (mut web, mut robot, mut token) = (None, None, None);
        let deadline = Instant::now() + Duration::from_secs(60);
        // The start-up lines end with "Ctrl-C stops".
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let line = match lines.recv_timeout(left) {
                Ok(l) => l,
                Err(_) => {
                    let _ = child.kill();
                    panic!("vorl serve {args:?} printed no addresses (exit {:?})", child.wait());
                }
            };
            if let Some(a) = line.strip_prefix("page       http://") {
                web = Some(a.trim_end_matches('/').to_string());
            } else if let Some(a) = line.strip_prefix("robot port ") {
                robot = Some(a.trim().to_string());
            } else if let Some(t) = line.strip_prefix("token      ") {
                token = t.split_whitespace().next().map(String::from);
            } else if line == "Ctrl-C stops" {
                break;
            }
        }
        Server {
            child,
            web: web.unwrap_or_default(),
            robot: robot.unwrap_or_default(),
            token,
        }
    }

    fn robot(&self) -> Robot {
        Robot::connect(&self.robot)
    }

    fn get(&self, path: &str) -> (u16, Value) {
        http(&self.web, "GET", path, None, &[])
    }

    fn post(&self, path: &str, body: Value) -> (u16, Value) {
        let token: Vec<(&str, &str)> = self.token.iter().map(|t| ("X-Vorl-Token", t.as_str())).collect();
        http(&self.web, "POST", path, Some(&body.to_string()), &token)
    }

    /// Waits for `/api/last` to satisfy `ok`.
    fn last_when(&self, ok: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let (status, v) = self.get("/api/last");
            if status == 200 && ok(&v) {
                return v;
            }
            assert!(Instant::now() < deadline, "/api/last never became ready: {status} {v}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// SIGTERM, then the exit status (killed after 30 s).
    fn terminate(self) -> Option<i32> {
        self.signal("-TERM")
    }

    /// A signal (`-TERM`, `-INT`: what Ctrl-C sends), then the exit status (killed after 30 s).
    fn signal(mut self, which: &str) -> Option<i32> {
        let _ = Command::new("kill")
            .args([which, &self.child.id().to_string()])
            .status();
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                return s.code();
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A robot client: one connection, line by line.
struct Robot {
    stream: TcpStream,
    reader: BufReader<TcpStream>,
}

impl Robot {
    fn connect(addr: &str) -> Robot {
        let stream = TcpStream::connect(addr).expect("connect to the robot port");
        stream.set_read_timeout(Some(Duration::from_secs(60))).expect("timeout");
        let reader = BufReader::new(stream.try_clone().expect("clone"));
        Robot { stream, reader }
    }

    fn send(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).expect("send");
    }

    fn line(&mut self) -> String {
        let mut l = String::new();
        self.reader.read_line(&mut l).expect("read a line");
        assert!(l.ends_with('\n'), "line not ended by \\n: {l:?}");
        l.trim_end_matches('\n').to_string()
    }

    /// Sends a command and reads one answer: `(first line, part lines)`.
    fn ask(&mut self, command: &str) -> (String, Vec<String>) {
        self.send(format!("{command}\n").as_bytes());
        self.answer()
    }

    fn answer(&mut self) -> (String, Vec<String>) {
        let head = self.line();
        let mut parts = Vec::new();
        if head.starts_with("RES ") {
            loop {
                let l = self.line();
                if l == "END" {
                    break;
                }
                parts.push(l);
            }
            let n: usize = head
                .split(' ')
                .nth(2)
                .and_then(|n| n.parse().ok())
                .expect("RES <frame> <n>");
            assert_eq!(n, parts.len(), "{head}: {parts:?}");
        }
        (head, parts)
    }
}

/// One HTTP/1.1 request over a fresh connection; the status and the body as JSON (`null`
/// when it is not JSON).
fn http(host: &str, method: &str, path: &str, body: Option<&str>, headers: &[(&str, &str)]) -> (u16, Value) {
    let (status, bytes) = http_raw(host, method, path, body.map(str::as_bytes), headers);
    (status, serde_json::from_slice(&bytes).unwrap_or(Value::Null))
}

fn http_raw(host: &str, method: &str, path: &str, body: Option<&[u8]>, headers: &[(&str, &str)]) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(host).expect("connect to the page");
    s.set_read_timeout(Some(Duration::from_secs(60))).expect("timeout");
    let body = body.unwrap_or_default();
    let mut req = format!(
        "{method} {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\nContent-Type: application/json\r\nContent-Length: {}\r\n",
        body.len()
    );
    for (k, v) in headers {
        req += &format!("{k}: {v}\r\n");
    }
    req += "\r\n";
    s.write_all(req.as_bytes()).expect("send request");
    s.write_all(body).expect("send body");
    // The header block, then Content-Length bytes (or all up to the close).
    let mut reader = BufReader::new(s);
    let mut head = String::new();
    loop {
        let mut line = String::new();
        let n = reader.read_line(&mut line).expect("read response");
        if n == 0 || line == "\r\n" {
            break;
        }
        head += &line;
    }
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no status in {head:?}"));
    let lower = head.to_ascii_lowercase();
    assert!(
        !lower.contains("transfer-encoding: chunked"),
        "a chunked answer: {head}"
    );
    let length = lower
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .and_then(|v| v.trim().parse::<usize>().ok());
    let mut body = Vec::new();
    match length {
        Some(n) => {
            body.resize(n, 0);
            reader.read_exact(&mut body).expect("read body");
        }
        None => {
            reader.read_to_end(&mut body).expect("read body");
        }
    }
    (status, body)
}

/// `vorl detect SET --json [extra]`: parts per frame name.
fn detect_json(set: &Path, extra: &[&str]) -> Value {
    let mut args: Vec<String> = vec!["detect".into(), set.display().to_string(), "--json".into()];
    args.extend(extra.iter().map(|s| s.to_string()));
    vorl(&args).success().json()["frames"].clone()
}

/// The robot line of a part of `vorl detect --json`, formatted here from the protocol's
/// definition: class or "?", x, y, angle (3 decimals), flipped 0/1, score (3 decimals).
fn expected_line(p: &Value) -> String {
    let class = p["class"].as_str().unwrap_or("?");
    let (x, y, a) = match p.get("robot") {
        Some(r) => (r["x"].as_f64(), r["y"].as_f64(), r["angle_deg"].as_f64()),
        None => (p["x"].as_f64(), p["y"].as_f64(), p["angle_deg"].as_f64()),
    };
    let f3 = |v: Option<f64>| match v {
        Some(v) => {
            let s = format!("{v:.3}");
            if s == "-0.000" {
                "0.000".to_string()
            } else {
                s
            }
        }
        None => "nan".to_string(),
    };
    let flipped = u8::from(p["flipped"].as_bool() == Some(true));
    format!(
        "{class} {} {} {} {flipped} {}",
        f3(x),
        f3(y),
        f3(a),
        f3(p["score"].as_f64())
    )
}

fn res_frame(head: &str) -> String {
    assert!(head.starts_with("RES "), "not a result: {head}");
    head.split(' ').nth(1).unwrap_or_default().to_string()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for e in std::fs::read_dir(from).expect("read dir").flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).expect("copy");
        }
    }
}

#[test]
fn robot_port_and_api_answer_what_detect_gives() {
    let set = plant();
    let expected = detect_json(&set, &[]);
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--fps", "20"]);
    let mut robot = server.robot();
    assert_eq!(robot.ask("PING"), ("PONG".to_string(), vec![]));
    for _ in 0..3 {
        let (head, lines) = robot.ask("TRG");
        let frame = res_frame(&head);
        let parts = expected[&frame]
            .as_array()
            .unwrap_or_else(|| panic!("no frame {frame}"));
        let want: Vec<String> = parts.iter().map(expected_line).collect();
        assert_eq!(lines, want, "{frame}");
        assert!(!want.is_empty());
    }
    // LAST answers the last frame processed, as /api/last does.
    let (head, lines) = robot.ask("LAST");
    let frame = res_frame(&head);
    let parts = expected[&frame].as_array().cloned().unwrap_or_default();
    assert_eq!(lines, parts.iter().map(expected_line).collect::<Vec<_>>());
    let last = server.last_when(|_| true);
    let frame = last["frame"].as_str().unwrap_or_default().to_string();
    assert_eq!(last["frames"][&frame], expected[&frame], "/api/last {frame}");
    assert!(last["timing"]["core_ms"].as_f64().is_some_and(|t| t > 0.0), "{last}");
    // A few frames on, the frame rate is measured, near the asked 20 fps.
    let later = server.last_when(|v| v["seq"].as_u64() > last["seq"].as_u64().map(|s| s + 10));
    let fps = later["timing"]["fps"].as_f64().unwrap_or_default();
    assert!((2.0..=25.0).contains(&fps), "fps {fps}");
    // POST /api/trigger: the next frame's result, in the same shape.
    let (status, next) = server.post("/api/trigger", json!({}));
    assert_eq!(status, 200, "{next}");
    let f = next["frame"].as_str().unwrap_or_default().to_string();
    assert_eq!(next["frames"][&f], expected[&f]);
    assert!(next["seq"].as_u64() > later["seq"].as_u64());
    // The overlay picture is a PNG of the frame's size.
    let (status, png) = http_raw(&server.web, "GET", "/api/overlay.png", None, &[]);
    assert_eq!(status, 200);
    let img = image::load_from_memory(&png).expect("a PNG");
    assert_eq!((img.width(), img.height()), (640, 480));
    assert_eq!(server.terminate(), Some(0));
}

/// The overlay's shapes (`/api/overlay.json`) against what `vorl detect --json` gives for the
/// frame: a part each, its cross at the part's position (rounded, as the overlay draws it), its
/// label naming its class ("unknown" for none), a closed border of many steps, an arrow and
/// an aligned outline for a known part; the caption counts the parts.
fn assert_overlay_matches(shapes: &Value, want: &Value) {
    let want = want.as_array().cloned().unwrap_or_default();
    let parts = shapes["parts"].as_array().cloned().unwrap_or_default();
    assert_eq!(parts.len(), want.len(), "{shapes}");
    let caption = shapes["caption"]["text"].as_str().unwrap_or_default();
    assert!(caption.starts_with(&format!("{} part(s), ", want.len())), "{caption}");
    for (p, w) in parts.iter().zip(&want) {
        let at = |k: &str| w[k].as_f64().map(|v| v.round() as i64);
        assert_eq!(
            (p["cross"][0].as_i64(), p["cross"][1].as_i64()),
            (at("x"), at("y")),
            "{p} / {w}"
        );
        let class = w["class"].as_str().unwrap_or("unknown");
        let text = p["label"]["text"].as_str().unwrap_or_default();
        assert!(text == class || text.starts_with(&format!("{class} ")), "{text} / {w}");
        let border = p["border"].as_str().unwrap_or_default().split(['l', 'L']).count();
        assert!(border > 20, "{border} border points: {p}");
        if !w["class"].is_null() {
            assert_eq!(p["arrow"].as_array().map(Vec::len), Some(3), "{p}");
            assert!(p["outline"].as_str().is_some_and(|o| o.split(' ').count() > 20), "{p}");
        }
        let colour = p["colour"].as_str().unwrap_or_default();
        assert!(colour.len() == 7 && colour.starts_with('#'), "{colour}");
    }
}

#[test]
fn bad_lines_get_errors_and_the_rest_goes_on() {
    let set = plant();
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--fps", "20"]);
    let mut robot = server.robot();
    let err = |r: &mut Robot, cmd: &[u8]| {
        r.send(cmd);
        let (head, _) = r.answer();
        assert!(head.starts_with("ERR "), "{:?} → {head}", String::from_utf8_lossy(cmd));
        head
    };
    assert!(err(&mut robot, b"FIRE\n").contains("unknown command"));
    assert!(err(&mut robot, b"\n").contains("empty"));
    assert!(err(&mut robot, b"PI\xffNG\n").contains("ASCII"));
    // A line over 256 bytes: one ERR, at once, before its end arrives; the rest of it is skipped.
    let long = vec![b'A'; 300];
    robot.send(&long);
    let (head, _) = robot.answer();
    assert!(head.contains("longer than 256"), "{head}");
    robot.send(&[b'B'; 5000]);
    robot.send(b"\n");
    // Exactly 256 bytes is taken (and is an unknown command); then PING still answers.
    assert!(err(&mut robot, &[vec![b'C'; 256], b"\n".to_vec()].concat()).contains("unknown command"));
    assert_eq!(robot.ask("ping").0, "PONG");
    // Several clients at once, each asking for triggers and the last result.
    let addr = server.robot.clone();
    let clients: Vec<_> = (0..4)
        .map(|_| {
            let addr = addr.clone();
            std::thread::spawn(move || {
                let mut r = Robot::connect(&addr);
                let mut frames = Vec::new();
                for _ in 0..3 {
                    let (head, _) = r.ask("TRG");
                    frames.push(res_frame(&head));
                    assert!(r.ask("LAST").0.starts_with("RES "));
                }
                frames
            })
        })
        .collect();
    // Clients that go away mid-answer or while waiting on a trigger harm nobody.
    for _ in 0..5 {
        let mut gone = Robot::connect(&addr);
        gone.send(b"TRG\nLAST\nTRG\n");
        let mut one = [0u8; 3];
        let _ = gone.stream.read(&mut one);
        drop(gone);
        let mut gone = Robot::connect(&addr);
        gone.send(b"TRG\n");
        drop(gone);
    }
    for c in clients {
        let frames = c.join().expect("a client thread");
        assert_eq!(frames.len(), 3);
    }
    assert_eq!(robot.ask("PING").0, "PONG");
    let (head, _) = robot.ask("TRG");
    res_frame(&head);
    // The page's API: bad requests get JSON errors, the server goes on.
    assert_eq!(server.get("/nope").0, 404);
    let (status, v) = http(&server.web, "POST", "/api/params", Some("{not json"), &[]);
    assert_eq!(status, 400, "{v}");
    assert!(v["error"].as_str().is_some_and(|e| e.contains("not JSON")), "{v}");
    let (status, v) = server.post("/api/params", json!({"no_such_key": 1}));
    assert_eq!(status, 400, "{v}");
    let (status, v) = server.post("/api/params", json!({"epsilon": "high"}));
    assert_eq!(status, 400, "{v}");
    let (status, v) = server.post("/api/params", json!([1, 2]));
    assert_eq!(status, 400, "{v}");
    let (status, v) = server.post("/api/teach", json!({"x": 1, "y": 2, "name": "../../escape"}));
    assert_eq!(status, 400, "{v}");
    let (status, v) = server.post("/api/teach", json!({"x": "a", "y": 2, "name": "ok"}));
    assert_eq!(status, 400, "{v}");
    let (status, v) = server.post("/api/calibrate", json!({"points": [[1, 2, 3]]}));
    assert_eq!(status, 400, "{v}");
    let (status, v) = server.post("/api/calibrate", json!({"points": [[1, 2, 3, 4]]}));
    assert_eq!(status, 400, "{v}");
    assert!(!set.join("../escape.png").exists() && !set.join("cal.json").exists());
    assert_eq!(robot.ask("PING").0, "PONG");
    assert_eq!(server.get("/api/last").0, 200);
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn trigger_mode_runs_one_frame_per_trigger_and_tuning_reruns_it() {
    let set = plant();
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger"]);
    let mut robot = server.robot();
    let (head, _) = robot.ask("LAST");
    assert_eq!(head, "ERR no frame yet");
    assert_eq!(server.get("/api/last").0, 503);
    assert_eq!(res_frame(&robot.ask("TRG").0), "f000.png");
    assert_eq!(res_frame(&robot.ask("TRG").0), "f001.png");
    std::thread::sleep(Duration::from_millis(300));
    // Nothing runs between triggers.
    assert_eq!(res_frame(&robot.ask("LAST").0), "f001.png");
    let (status, v) = server.post("/api/trigger", json!({}));
    assert_eq!((status, v["frame"].as_str()), (200, Some("f002.png")));
    // A parameter changed on the page applies to the frame on screen at once: the same
    // frame, run again, as `vorl detect --epsilon 0.003 --touching-parts true` gives it.
    let before = server.last_when(|_| true);
    let (status, v) = server.post("/api/params", json!({"epsilon": 0.003, "touching_parts": true}));
    assert_eq!(status, 200, "{v}");
    let after = server.last_when(|v| v["version"].as_u64() > before["version"].as_u64());
    assert_eq!(after["frame"], "f002.png");
    assert_eq!(after["seq"], before["seq"]);
    let want = detect_json(&set, &["--epsilon", "0.003", "--touching-parts", "true"]);
    assert_eq!(after["frames"]["f002.png"], want["f002.png"]);
    assert_ne!(after["frames"]["f002.png"], before["frames"]["f002.png"]);
    let (_, params) = server.get("/api/params");
    assert_eq!(params["config"]["touching_parts"], true);
    // What the page shows of a publication: the frame itself, and the overlay's shapes, a
    // part each where detect puts it, labelled with its class; the one before the last is
    // still served by its version (the page may ask for it just after the next came).
    let frame = image::open(set.join("frames/f002.png")).expect("f002").to_luma8();
    let default = detect_json(&set, &[]);
    for (version, want) in [(&after["version"], &want), (&before["version"], &default)] {
        let (status, bmp) = http_raw(&server.web, "GET", &format!("/api/frame.bmp?v={version}"), None, &[]);
        assert_eq!(status, 200);
        let shown = image::load_from_memory_with_format(&bmp, image::ImageFormat::Bmp)
            .expect("a BMP")
            .to_luma8();
        assert!(shown == frame, "the page's picture of version {version} is f002 itself");
        let (status, shapes) = server.get(&format!("/api/overlay.json?v={version}"));
        assert_eq!(status, 200, "{shapes}");
        assert_eq!((&shapes["version"], &shapes["frame"]), (version, &json!("f002.png")));
        assert_overlay_matches(&shapes, &want["f002.png"]);
    }
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn teach_and_save_give_what_detect_then_finds() {
    let dir = Scratch::new("serve-teach");
    let set = dir.join("set");
    copy_dir(&plant(), &set);
    // The washer is not taught; f000 holds two.
    std::fs::remove_file(set.join("templates/washer.png")).expect("washer template");
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(set.join("truth.json")).expect("truth")).expect("json");
    let washer = truth["frames"]["f000.png"]
        .as_array()
        .and_then(|a| a.iter().find(|p| p["class"] == "washer"))
        .cloned()
        .expect("a washer in f000");
    let (wx, wy) = (washer["x"].as_f64().unwrap_or(0.0), washer["y"].as_f64().unwrap_or(0.0));
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger", "--require-token"]);
    let token = server.token.clone().expect("a token printed");
    let mut robot = server.robot();
    robot.ask("TRG");
    let before = server.last_when(|_| true);
    let near = |v: &Value, class: &str| {
        v["frames"]["f000.png"].as_array().is_some_and(|a| {
            a.iter().any(|p| {
                p["class"] == class
                    && (p["x"].as_f64().unwrap_or(0.0) - wx).hypot(p["y"].as_f64().unwrap_or(0.0) - wy) < 1.0
            })
        })
    };
    assert!(!near(&before, "ring"));
    // Without the token: refused, nothing written.
    let (status, v) = http(
        &server.web,
        "POST",
        "/api/teach",
        Some(&json!({"x": wx, "y": wy, "name": "ring"}).to_string()),
        &[("X-Vorl-Token", "wrong")],
    );
    assert_eq!(status, 403, "{v}");
    // With it (as a query, as the page sends it when opened with ?token=).
    let (status, v) = http(
        &server.web,
        "POST",
        &format!("/api/teach?token={token}"),
        Some(&json!({"x": wx, "y": wy, "name": "ring"}).to_string()),
        &[],
    );
    assert_eq!(status, 200, "{v}");
    let taught = server.last_when(|v| v["version"].as_u64() > before["version"].as_u64());
    assert!(
        near(&taught, "ring"),
        "the taught part is named on the frame on screen: {taught}"
    );
    // Not in the set until saved.
    assert!(!set.join("templates/ring.png").exists());
    let (status, v) = server.post("/api/save", json!({}));
    assert_eq!(status, 200, "{v}");
    assert!(set.join("templates/ring.png").is_file());
    assert!(set.join("vorl.toml").is_file());
    // `vorl detect SET` now gives what the page showed.
    let want = detect_json(&set, &[]);
    assert_eq!(taught["frames"]["f000.png"], want["f000.png"]);
    // The next frame matches it too.
    let (head, lines) = robot.ask("TRG");
    assert_eq!(res_frame(&head), "f001.png");
    let want_lines = lines_of(&want["f001.png"]);
    assert_eq!(lines, want_lines);
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn calibration_from_the_page_is_what_vorl_calibrate_makes() {
    let dir = Scratch::new("serve-cal");
    let set = dir.join("set");
    copy_dir(&plant(), &set);
    let points = [
        [40.0, 40.0, -212.085, 223.689],
        [320.0, 40.0, 42.579, 214.087],
        [600.0, 40.0, 294.420, 204.590],
        [40.0, 240.0, -205.314, 47.907],
        [320.0, 240.0, 50.841, 39.231],
        [600.0, 240.0, 304.140, 30.653],
        [40.0, 440.0, -198.461, -130.012],
        [320.0, 440.0, 59.203, -137.737],
        [600.0, 440.0, 313.977, -145.374],
    ];
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger"]);
    let mut robot = server.robot();
    robot.ask("TRG");
    let (status, v) = server.post("/api/calibrate", json!({ "points": points }));
    assert_eq!(status, 200, "{v}");
    let csv = dir.join("points.csv");
    let mut text = String::from("u,v,x,y\n");
    for p in points {
        text += &format!("{},{},{},{}\n", p[0], p[1], p[2], p[3]);
    }
    std::fs::write(&csv, text).expect("csv");
    let cal = dir.join("cal.json");
    vorl([
        "calibrate",
        "--points",
        csv.to_str().unwrap_or_default(),
        "--out",
        cal.to_str().unwrap_or_default(),
    ])
    .success();
    assert_eq!(
        std::fs::read_to_string(&cal).expect("cal"),
        std::fs::read_to_string(set.join("cal.json")).expect("the set's cal.json")
    );
    // The robot now gets platform coordinates, as detect --calibration gives them.
    let want = detect_json(&set, &["--calibration", cal.to_str().unwrap_or_default()]);
    let (head, lines) = robot.ask("LAST");
    assert_eq!(res_frame(&head), "f000.png");
    let want_lines = lines_of(&want["f000.png"]);
    assert!(want["f000.png"][0].get("robot").is_some());
    assert_eq!(lines, want_lines);
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn sigterm_stops_cleanly_and_the_recording_replays() {
    let dir = Scratch::new("serve-record");
    let rec = dir.join("rec");
    let demo = dir.join("demo");
    let server = Server::start(&[
        demo.to_str().unwrap_or_default(),
        "--source",
        "gen",
        "--seed",
        "5",
        "--fps",
        "20",
        "--record",
        rec.to_str().unwrap_or_default(),
    ]);
    assert!(demo.join("templates").is_dir(), "the generator's set is written first");
    let last = server.last_when(|v| v["seq"].as_u64() >= Some(3));
    assert!(last["frame"].as_str().is_some_and(|f| f.starts_with('g')), "{last}");
    let code = server.terminate();
    assert_eq!(code, Some(0));
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(rec.join("truth.json")).expect("truth.json")).expect("json");
    let frames = truth["frames"].as_object().cloned().unwrap_or_default();
    let files = std::fs::read_dir(rec.join("frames")).map(|d| d.count()).unwrap_or(0);
    assert!(frames.len() >= 3, "{} frames recorded", frames.len());
    assert_eq!(frames.len(), files, "every frame written has its result");
    // `vorl detect` on the recording gives what was served, and eval and check run on it.
    let replay = detect_json(&rec, &[]);
    for (name, parts) in &frames {
        assert_eq!(&replay[name], parts, "{name}");
    }
    vorl(["eval", rec.to_str().unwrap_or_default()]).success();
    vorl(["check", rec.to_str().unwrap_or_default()]).success();
}

#[test]
fn addresses_off_loopback_need_listen() {
    let out = vorl(["serve", plant().to_str().unwrap_or_default(), "--http", "0.0.0.0:0"]).failure();
    assert!(
        out.stderr.contains("not on loopback") && out.stderr.contains("--listen"),
        "{}",
        out.stderr
    );
    let out = vorl([
        "serve",
        plant().to_str().unwrap_or_default(),
        "--robot",
        "10.1.2.3:9000",
    ])
    .failure();
    assert!(out.stderr.contains("not on loopback"), "{}", out.stderr);
    for fps in ["-1", "1001", "nan"] {
        let flag = format!("--fps={fps}");
        let out = vorl(["serve", plant().to_str().unwrap_or_default(), &flag]).failure();
        assert!(out.stderr.contains("--fps"), "{fps}: {}", out.stderr);
    }
}

#[test]
fn fps_0_runs_as_fast_as_the_frames_are_processed() {
    let set = plant();
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--fps", "0"]);
    let first = server.last_when(|_| true);
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs(2));
    let later = server.last_when(|_| true);
    let frames = later["seq"].as_u64().unwrap_or(0) - first["seq"].as_u64().unwrap_or(0);
    let seconds = t0.elapsed().as_secs_f64();
    // Paced at the default 10 fps this would be about 20 frames; unpaced, a frame here takes a
    // few ms (core_ms tells), so there are several times more.
    let frame_ms = later["timing"]["frame_ms"].as_f64().unwrap_or(f64::NAN);
    assert!(
        frames as f64 > 40.0 * seconds,
        "{frames} frames in {seconds:.1} s ({frame_ms:.1} ms a frame)"
    );
    // Unpaced, the robot still gets every answer whole.
    let expected = detect_json(&set, &[]);
    let mut robot = server.robot();
    for _ in 0..20 {
        let (head, lines) = robot.ask("TRG");
        check_result(&head, &lines, &expected);
    }
    assert_eq!(server.terminate(), Some(0));
}

/// Headless Chromium driven through chromedriver's WebDriver HTTP API.
struct Browser {
    driver: Child,
    host: String,
    session: String,
    _profile: Scratch,
}

/// The W3C WebDriver key of an element reference.
const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

impl Browser {
    /// A browser, or `None` (the test skipped, saying so) when Chromium or chromedriver is
    /// absent outside CI; in CI (`CI` set) their absence fails the test: set-up installs them.
    fn start() -> Option<Browser> {
        let find = |names: &[&str]| {
            let path = std::env::var_os("PATH").unwrap_or_default();
            names
                .iter()
                .flat_map(|n| std::env::split_paths(&path).map(move |d| d.join(n)))
                .find(|p| p.is_file())
        };
        let chromium = find(&["chromium", "chromium-browser", "google-chrome"]);
        let driver = find(&["chromedriver"]);
        let (Some(chromium), Some(driver)) = (chromium, driver) else {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI: chromium and chromedriver must be installed (scripts/setup.sh installs them)"
            );
            eprintln!(
                "skipped: the browser test needs chromium and chromedriver (bash scripts/setup.sh installs them)"
            );
            return None;
        };
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .expect("a free port");
        let child = Command::new(driver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start chromedriver");
        let host = format!("127.0.0.1:{port}");
        let profile = Scratch::new("chromium-profile");
        let mut browser = Browser {
            driver: child,
            host,
            session: String::new(),
            _profile: profile,
        };
        let deadline = Instant::now() + Duration::from_secs(30);
        while TcpStream::connect(&browser.host).is_err() {
            assert!(Instant::now() < deadline, "chromedriver did not start");
            std::thread::sleep(Duration::from_millis(100));
        }
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-dev-shm-usage",
            "--window-size=1400,1000",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([format!("--user-data-dir={}", browser._profile.join("p").display())])
        .collect::<Vec<_>>();
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": chromium.display().to_string(), "args": args}
        }}});
        let (status, v) = http(&browser.host, "POST", "/session", Some(&caps.to_string()), &[]);
        assert_eq!(status, 200, "new session: {v}");
        browser.session = v["value"]["sessionId"].as_str().expect("a session id").to_string();
        Some(browser)
    }

    fn call(&self, method: &str, path: &str, body: Value) -> Value {
        let path = format!("/session/{}{path}", self.session);
        let (status, v) = http(&self.host, method, &path, Some(&body.to_string()), &[]);
        assert_eq!(status, 200, "{method} {path}: {v}");
        v["value"].clone()
    }

    fn goto(&self, url: &str) {
        self.call("POST", "/url", json!({ "url": url }));
    }

    fn exec(&self, script: &str) -> Value {
        self.call("POST", "/execute/sync", json!({"script": script, "args": []}))
    }

    /// Runs `script` until it returns something truthy (or fails after 60 s).
    fn wait_for(&self, script: &str) -> Value {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let v = self.exec(script);
            let truthy = !matches!(&v, Value::Null | Value::Bool(false)) && v != json!(0) && v != json!("");
            if truthy {
                return v;
            }
            if Instant::now() > deadline {
                let msg =
                    self.exec("return document.getElementById('msg') && document.getElementById('msg').textContent");
                panic!("never true in the page: {script} (its message: {msg})");
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    fn find(&self, css: &str) -> String {
        let v = self.call("POST", "/element", json!({"using": "css selector", "value": css}));
        v[ELEMENT]
            .as_str()
            .unwrap_or_else(|| panic!("no element {css}: {v}"))
            .to_string()
    }

    fn click(&self, css: &str) {
        let id = self.find(css);
        self.call("POST", &format!("/element/{id}/click"), json!({}));
    }

    fn type_into(&self, css: &str, text: &str) {
        let id = self.find(css);
        self.call("POST", &format!("/element/{id}/value"), json!({ "text": text }));
    }

    /// A real mouse click at (dx, dy) px from the element's centre.
    fn click_at(&self, css: &str, dx: i64, dy: i64) {
        let id = self.find(css);
        self.call(
            "POST",
            "/actions",
            json!({"actions": [{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
            "actions": [
                {"type": "pointerMove", "duration": 0, "origin": {ELEMENT: id}, "x": dx, "y": dy},
                {"type": "pointerDown", "button": 0},
                {"type": "pointerUp", "button": 0}
            ]}]}),
        );
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let _ = http(&self.host, "DELETE", &format!("/session/{}", self.session), None, &[]);
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

/// The page's row of a part of `vorl detect --json`, from the page's columns: class (or
/// "unknown"), x, y, angle (2 decimals), flipped yes/no, f′ (4 decimals), verification.
fn expected_row(p: &Value) -> Vec<String> {
    let f = |k: &str, d: usize| p[k].as_f64().map_or("–".to_string(), |v| format!("{v:.d$}"));
    let verify = match (p["verify_px"].as_f64(), p["verify_limit"].as_f64()) {
        (Some(v), Some(l)) => format!("{v:.2} / {l:.2}"),
        _ => "–".to_string(),
    };
    vec![
        p["class"].as_str().unwrap_or("unknown").to_string(),
        f("x", 2),
        f("y", 2),
        f("angle_deg", 2),
        if p["flipped"].as_bool() == Some(true) {
            "yes"
        } else {
            "no"
        }
        .to_string(),
        f("score", 4),
        verify,
    ]
}

/// The robot port's part lines for one frame of `vorl detect --json` ([`expected_line`] of
/// each part; none for a frame it does not hold).
fn lines_of(frame: &Value) -> Vec<String> {
    frame
        .as_array()
        .map(|a| a.iter().map(expected_line).collect())
        .unwrap_or_default()
}

/// The page's table rows for one frame of `vorl detect --json` ([`expected_row`] of each
/// part; none for a frame it does not hold).
fn rows_of(frame: &Value) -> Vec<Vec<String>> {
    frame
        .as_array()
        .map(|a| a.iter().map(expected_row).collect())
        .unwrap_or_default()
}

/// A copy of `examples/plant` in a scratch folder tagged `tag`, its washer template removed (the
/// page teaches it), with the set's folder and its truth.
fn plant_without_washer(tag: &str) -> (Scratch, PathBuf, Value) {
    let dir = Scratch::new(tag);
    let set = dir.join("set");
    copy_dir(&plant(), &set);
    std::fs::remove_file(set.join("templates/washer.png")).expect("washer template");
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(set.join("truth.json")).expect("truth")).expect("json");
    (dir, set, truth)
}

const ROWS: &str =
    "return [...document.querySelectorAll('#parts tbody tr')].map(r => [...r.cells].map(c => c.textContent))";

#[test]
fn the_page_in_a_browser_shows_teaches_tunes_saves_and_calibrates() {
    let Some(browser) = Browser::start() else {
        return;
    };
    let (dir, set, truth) = plant_without_washer("serve-page");
    let washer = truth["frames"]["f000.png"]
        .as_array()
        .and_then(|a| a.iter().find(|p| p["class"] == "washer"))
        .cloned()
        .expect("a washer in f000");
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger", "--require-token"]);
    let token = server.token.clone().expect("a token");
    assert_eq!(res_frame(&server.robot().ask("TRG").0), "f000.png");
    browser.goto(&format!("http://{}/?token={token}", server.web));
    // The live frame: its name, the overlay picture, the parts' table as detect gives them.
    browser.wait_for("return document.getElementById('fname').textContent === 'f000.png'");
    let width = browser.wait_for("const i = document.getElementById('frame'); return i.complete && i.naturalWidth");
    assert_eq!(width, json!(640));
    let want = detect_json(&set, &[]);
    let rows = browser.exec(ROWS);
    let want_rows = rows_of(&want["f000.png"]);
    assert_eq!(rows, json!(want_rows));
    let core: f64 = browser
        .exec("return document.getElementById('core').textContent")
        .as_str()
        .and_then(|t| t.parse().ok())
        .unwrap_or(0.0);
    assert!(core > 0.0, "frame time shown");
    // Teach: a real click on the washer, a name typed, the button pressed.
    let shown = browser.exec("return document.getElementById('frame').getBoundingClientRect().width");
    let k = shown.as_f64().unwrap_or(640.0) / 640.0;
    let (wx, wy) = (washer["x"].as_f64().unwrap_or(0.0), washer["y"].as_f64().unwrap_or(0.0));
    browser.click_at(
        "#frame",
        ((wx - 320.0) * k).round() as i64,
        ((wy - 240.0) * k).round() as i64,
    );
    browser.wait_for("return document.getElementById('tpoint').textContent.includes(',')");
    browser.type_into("#tname", "ring");
    browser.click("#teach");
    let msg = browser.wait_for("const m = document.getElementById('msg').textContent; return m.length > 0 && m");
    assert!(msg.as_str().is_some_and(|m| m.starts_with("taught ring")), "{msg}");
    browser.wait_for(&format!("{ROWS}.some(r => r[0] === 'ring')").replacen("return ", "return ", 1));
    // Tune: the touching-parts box turned over, applied at once.
    let was = browser.exec("return document.getElementById('p-touching_parts').checked") == json!(true);
    browser.click("#p-touching_parts");
    browser.wait_for(&format!(
        "return document.getElementById('msg').textContent.includes('touching_parts = {}: applied')",
        !was
    ));
    assert_eq!(server.get("/api/params").1["config"]["touching_parts"], json!(!was));
    // Save: the set now detects what the page shows.
    browser.click("#save");
    browser.wait_for("return document.getElementById('msg').textContent.startsWith('saved')");
    assert!(set.join("templates/ring.png").is_file());
    let want = detect_json(&set, &[]);
    let rows = browser.wait_for(&format!(
        "const rows = {}; return rows.some(r => r[0] === 'ring') && rows",
        ROWS.trim_start_matches("return ")
    ));
    let want_rows = rows_of(&want["f000.png"]);
    assert_eq!(rows, json!(want_rows));
    assert!(want_rows.iter().any(|r| r[0] == "ring"));
    // Calibrate: marks clicked on the frame, their robot coordinates typed, saved; the set's
    // cal.json is what `vorl calibrate` makes of the same points.
    browser.click("input[name=click][value=calibrate]");
    let marks = [
        (40.0, 40.0, "-212.085", "223.689"),
        (600.0, 40.0, "294.420", "204.590"),
        (320.0, 240.0, "50.841", "39.231"),
        (40.0, 440.0, "-198.461", "-130.012"),
        (600.0, 440.0, "313.977", "-145.374"),
    ];
    for (i, (u, v, x, y)) in marks.iter().enumerate() {
        browser.click_at(
            "#frame",
            ((u - 320.0) * k).round() as i64,
            ((v - 240.0) * k).round() as i64,
        );
        let row = format!("#calpoints tbody tr:nth-child({})", i + 1);
        browser.type_into(&format!("{row} .cal-x"), x);
        browser.type_into(&format!("{row} .cal-y"), y);
    }
    let points = browser.exec("return calPoints");
    browser.click("#calsave");
    browser.wait_for("return document.getElementById('msg').textContent.startsWith('calibration from 5 points')");
    let mut csv = String::from("u,v,x,y\n");
    for p in points.as_array().cloned().unwrap_or_default() {
        let n: Vec<f64> = (0..4).map(|j| p[j].as_f64().unwrap_or(f64::NAN)).collect();
        csv += &format!("{},{},{},{}\n", n[0], n[1], n[2], n[3]);
    }
    assert_eq!(csv.lines().count(), 6, "{points}");
    std::fs::write(dir.join("points.csv"), csv).expect("csv");
    let cal = dir.join("cal.json");
    vorl([
        "calibrate",
        "--points",
        dir.join("points.csv").to_str().unwrap_or_default(),
        "--out",
        cal.to_str().unwrap_or_default(),
    ])
    .success();
    assert_eq!(
        std::fs::read_to_string(&cal).expect("cal"),
        std::fs::read_to_string(set.join("cal.json")).expect("the set's cal.json")
    );
    let want = detect_json(&set, &["--calibration", cal.to_str().unwrap_or_default()]);
    let (head, lines) = server.robot().ask("LAST");
    assert_eq!(res_frame(&head), "f000.png");
    let want_lines = lines_of(&want["f000.png"]);
    assert_eq!(lines, want_lines);
    drop(browser);
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn a_frame_that_cannot_be_read_is_an_error_and_the_next_goes_on() {
    let dir = Scratch::new("serve-bad-frame");
    let set = dir.join("set");
    copy_dir(&plant(), &set);
    // Between f000.png and f001.png in name order: not a PNG.
    std::fs::write(set.join("frames/f000b.png"), b"not a picture").expect("write");
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger"]);
    let mut robot = server.robot();
    assert_eq!(res_frame(&robot.ask("TRG").0), "f000.png");
    let (head, _) = robot.ask("TRG");
    assert!(head.starts_with("ERR frame f000b.png: "), "{head}");
    assert!(robot.ask("LAST").0.starts_with("ERR frame f000b.png"));
    let (status, v) = server.get("/api/last");
    assert_eq!(status, 200);
    assert!(v["error"].as_str().is_some_and(|e| e.contains("f000b.png")), "{v}");
    assert_eq!(res_frame(&robot.ask("TRG").0), "f001.png");
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn ctrl_c_finishes_the_frame_in_hand_and_flushes_the_recording() {
    let dir = Scratch::new("serve-int");
    let rec = dir.join("rec");
    let set = plant();
    let server = Server::start(&[
        set.to_str().unwrap_or_default(),
        "--trigger",
        "--record",
        rec.to_str().unwrap_or_default(),
    ]);
    let mut robot = server.robot();
    for want in ["f000.png", "f001.png", "f002.png"] {
        assert_eq!(res_frame(&robot.ask("TRG").0), want);
    }
    // Fewer frames than a flush holds: only the stop writes truth.json.
    assert!(!rec.join("truth.json").exists());
    let scratch = format!("vorl-serve-{}-", server.child.id());
    let leftovers = || {
        std::fs::read_dir(std::env::temp_dir())
            .map(|d| {
                d.flatten()
                    .filter(|e| e.file_name().to_string_lossy().starts_with(&scratch))
                    .count()
            })
            .unwrap_or(0)
    };
    assert_eq!(leftovers(), 1, "the server's scratch folder (templates being taught)");
    assert_eq!(server.signal("-INT"), Some(0));
    assert_eq!(leftovers(), 0, "the scratch folder is removed at the stop");
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(rec.join("truth.json")).expect("truth.json")).expect("json");
    let expected = detect_json(&set, &[]);
    let recorded = truth["frames"].as_object().cloned().unwrap_or_default();
    assert_eq!(recorded.len(), 3);
    for (name, from) in recorded.keys().zip(["f000.png", "f001.png", "f002.png"]) {
        assert_eq!(truth["frames"][name], expected[from], "{name} is {from}");
    }
    // The robot's connection was closed, not left hanging.
    let mut rest = String::new();
    assert_eq!(robot.reader.read_line(&mut rest).ok(), Some(0), "{rest:?}");
}

/// Checks one answer to `TRG` or `LAST` read off the wire: `RES <frame> <n>`, exactly n part
/// lines of the protocol's shape, `END`; and that the lines are what `vorl detect --json` gives
/// for the named frame. The frame's name.
fn check_result(head: &str, lines: &[String], expected: &Value) -> String {
    let fields: Vec<&str> = head.split(' ').collect();
    assert_eq!(fields.len(), 3, "RES <frame> <n>: {head:?}");
    assert_eq!(fields[0], "RES", "{head:?}");
    let n: usize = fields[2].parse().unwrap_or_else(|_| panic!("n in {head:?}"));
    assert_eq!(lines.len(), n, "{head}: {lines:?}");
    let three_decimals = |s: &str| {
        s == "nan"
            || s.split_once('.').is_some_and(|(i, d)| {
                d.len() == 3
                    && d.bytes().all(|b| b.is_ascii_digit())
                    && !i.trim_start_matches('-').is_empty()
                    && i.trim_start_matches('-').bytes().all(|b| b.is_ascii_digit())
            })
    };
    for l in lines {
        let f: Vec<&str> = l.split(' ').collect();
        assert_eq!(f.len(), 6, "<class> <x> <y> <angle_deg> <flipped> <score>: {l:?}");
        assert!(!f[0].is_empty() && f[0].is_ascii(), "{l:?}");
        assert!(f[1..4].iter().all(|v| three_decimals(v) && *v != "nan"), "{l:?}");
        assert!(f[4] == "0" || f[4] == "1", "{l:?}");
        assert!(three_decimals(f[5]), "{l:?}");
    }
    let frame = fields[1].to_string();
    let want: Vec<String> = expected[&frame]
        .as_array()
        .unwrap_or_else(|| panic!("no frame {frame} in detect's answer"))
        .iter()
        .map(expected_line)
        .collect();
    assert_eq!(lines, want, "{frame}");
    frame
}

/// Open file descriptors of a process (Linux), or `None` where /proc does not tell.
fn open_fds(pid: u32) -> Option<usize> {
    std::fs::read_dir(format!("/proc/{pid}/fd")).ok().map(|d| d.count())
}

#[test]
fn fifty_clients_at_once_each_get_complete_answers_and_rude_ones_harm_nobody() {
    const CLIENTS: usize = 50;
    const ROUNDS: usize = 3;
    let set = plant();
    let expected = detect_json(&set, &[]);
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--fps", "30"]);
    // A first frame, so that LAST has something to answer from the start.
    server.last_when(|_| true);
    let pid = server.child.id();
    let fds_before = open_fds(pid);
    let addr = server.robot.clone();
    let start = std::sync::Arc::new(std::sync::Barrier::new(CLIENTS + 1));
    let polite: Vec<_> = (0..CLIENTS)
        .map(|i| {
            let (addr, start, expected) = (addr.clone(), start.clone(), expected.clone());
            std::thread::spawn(move || {
                let mut r = Robot::connect(&addr);
                start.wait();
                let mut answers = 0;
                for round in 0..ROUNDS {
                    if (i + round) % 2 == 0 {
                        // Pipelined: three requests in one write, three answers in order.
                        r.send(b"TRG\nLAST\nPING\n");
                        let (head, lines) = r.answer();
                        check_result(&head, &lines, &expected);
                        let (head, lines) = r.answer();
                        check_result(&head, &lines, &expected);
                        assert_eq!(r.answer(), ("PONG".to_string(), vec![]));
                    } else {
                        assert_eq!(r.ask("PING"), ("PONG".to_string(), vec![]));
                        let (head, lines) = r.ask("LAST");
                        check_result(&head, &lines, &expected);
                        let (head, lines) = r.ask("trg");
                        check_result(&head, &lines, &expected);
                    }
                    answers += 3;
                }
                answers
            })
        })
        .collect();
    // Meanwhile, rude clients: gone after a few bytes of an answer, gone while waiting on a
    // trigger, and one that asks for much and reads nothing until the server must wait on it.
    let rude: Vec<_> = (0..10)
        .map(|_| {
            let addr = addr.clone();
            std::thread::spawn(move || {
                let mut gone = Robot::connect(&addr);
                gone.send(b"LAST\nTRG\nLAST\nPING\n");
                let mut few = [0u8; 5];
                let _ = gone.stream.read(&mut few);
                drop(gone);
                let mut gone = Robot::connect(&addr);
                gone.send(b"TRG\n");
                drop(gone);
            })
        })
        .collect();
    let mut stuck = Robot::connect(&addr);
    stuck
        .stream
        .set_write_timeout(Some(Duration::from_secs(1)))
        .expect("write timeout");
    // LAST after LAST until our writes block: the server's answers have filled both sockets'
    // buffers, and the server, which reads a client's next line only once its answer is
    // written, is waiting to write to this client.
    let many = "LAST\n".repeat(10_000);
    let mut blocked = false;
    for _ in 0..2_000 {
        if stuck.stream.write_all(many.as_bytes()).is_err() {
            blocked = true;
            break;
        }
    }
    assert!(blocked, "the stuck client's writes never blocked");
    start.wait();
    let t0 = Instant::now();
    let mut total = 0;
    for c in polite {
        total += c.join().expect("a polite client: complete, well-formed answers");
    }
    for c in rude {
        c.join().expect("a rude client");
    }
    assert_eq!(total, CLIENTS * ROUNDS * 3);
    assert!(
        t0.elapsed() < Duration::from_secs(60),
        "50 clients took {:?}",
        t0.elapsed()
    );
    // The stuck client goes away with the server still writing to it.
    drop(stuck);
    // The server goes on for everyone: a new client, the page's API, triggers.
    let mut after = server.robot();
    assert_eq!(after.ask("PING").0, "PONG");
    for _ in 0..2 {
        let (head, lines) = after.ask("TRG");
        check_result(&head, &lines, &expected);
    }
    assert_eq!(server.get("/api/last").0, 200);
    // And the connections of the clients gone are closed by the server, not left open.
    drop(after);
    if let Some(before) = fds_before {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let now = open_fds(pid).unwrap_or(usize::MAX);
            if now <= before + 1 {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "{now} file descriptors open, {before} before the clients"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
    assert_eq!(server.terminate(), Some(0));
}

/// In the page: once the frame picture and its overlay layer show the publication `version`,
/// the picture's pixels that are not gray (R, G and B not all equal: none, the picture is the
/// frame itself), the parts the SVG layer draws, their points (borders and outlines) and
/// crosses, and the caption.
const DRAWN: &str = "const i = document.getElementById('frame'), o = document.getElementById('overlay');
    if (!i.complete || !i.naturalWidth || !i.src.endsWith('v=' + arguments[0]) || o.dataset.version !== String(arguments[0])) return null;
    const c = document.createElement('canvas'); c.width = i.naturalWidth; c.height = i.naturalHeight;
    const g = c.getContext('2d'); g.drawImage(i, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let n = 0; for (let k = 0; k < d.length; k += 4) if (d[k] !== d[k + 1] || d[k + 1] !== d[k + 2]) n++;
    const parts = [...o.querySelectorAll('g.part')];
    const points = [...o.querySelectorAll('g.part path.border')].reduce((s, p) => s + p.getAttribute('d').split(/[lL]/).length, 0)
        + [...o.querySelectorAll('g.part polygon.outline')].reduce((s, p) => s + p.points.numberOfItems, 0);
    const r = o.getBoundingClientRect(), f = i.getBoundingClientRect();
    return {coloured: n, parts: parts.length, points, crosses: parts.map(p => p.dataset.cross),
        caption: o.lastElementChild.lastElementChild.textContent,
        over: Math.abs(r.width - f.width) < 1 && Math.abs(r.height - f.height) < 1 && Math.abs(r.left - f.left) < 1 && Math.abs(r.top - f.top) < 1};";

/// WebDriver's keys (the private-use code points of the W3C spec).
const KEY_HOME: char = '\u{E011}';
const KEY_END: char = '\u{E010}';
const KEY_RIGHT: char = '\u{E014}';

#[test]
fn the_threshold_slider_changes_the_overlay() {
    let Some(browser) = Browser::start() else {
        return;
    };
    let set = plant();
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger"]);
    assert_eq!(res_frame(&server.robot().ask("TRG").0), "f000.png");
    browser.goto(&format!("http://{}/", server.web));
    browser.wait_for("return document.getElementById('fname').textContent === 'f000.png'");
    // What the page draws for a publication: (parts, their polygons' points, their crosses).
    let drawn = |version: &Value| -> (u64, u64, Vec<String>) {
        let script = json!({"script": DRAWN, "args": [version]});
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let v = browser.call("POST", "/execute/sync", script.clone());
            if let Some(n) = v["parts"].as_u64() {
                assert_eq!(v["coloured"], json!(0), "the picture is the gray frame: {v}");
                assert_eq!(v["over"], json!(true), "the overlay lies over the picture: {v}");
                assert!(
                    v["caption"]
                        .as_str()
                        .is_some_and(|c| c.starts_with(&format!("{n} part(s), "))),
                    "{v}"
                );
                let crosses = v["crosses"]
                    .as_array()
                    .map(|a| a.iter().map(|c| c.as_str().unwrap_or_default().to_string()).collect())
                    .unwrap_or_default();
                return (n, v["points"].as_u64().unwrap_or_default(), crosses);
            }
            assert!(
                Instant::now() < deadline,
                "the picture of version {version} never showed"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    let before = server.last_when(|_| true);
    let parts_before = before["frames"]["f000.png"].as_array().map_or(0, Vec::len);
    assert!(parts_before > 0, "{before}");
    let (parts, points, _) = drawn(&before["version"]);
    assert_eq!(parts, parts_before as u64, "the overlay draws every part");
    assert!(points > 100, "the overlay draws the parts' outlines: {points} points");
    browser.wait_for(&format!(
        "return {}.length === {parts_before}",
        ROWS.trim_start_matches("return ")
    ));
    assert_eq!(
        browser.exec("return document.getElementById('threshold-slider').value"),
        json!(before_threshold(&server))
    );
    // The slider to its end, as a user does from the keyboard: the highest threshold, 255,
    // which no difference |I' − B| exceeds: nothing is foreground, no part, nothing drawn.
    browser.type_into("#threshold-slider", &KEY_END.to_string());
    browser.wait_for("return document.getElementById('msg').textContent === 'threshold = 255: applied'");
    assert_eq!(server.get("/api/params").1["config"]["threshold"], json!(255));
    let high = server.last_when(|v| v["version"].as_u64() > before["version"].as_u64());
    assert_eq!(high["frame"], "f000.png", "the frame on screen, run again");
    assert_eq!(high["frames"]["f000.png"], json!([]), "{high}");
    assert_eq!(drawn(&high["version"]).0, 0, "no part drawn at threshold 255");
    browser.wait_for(&format!("return {}.length === 0", ROWS.trim_start_matches("return ")));
    assert_eq!(
        browser.exec("return document.getElementById('p-threshold').value"),
        json!("255"),
        "the threshold's field follows the slider"
    );
    // The picture the page shows is the frame itself; the overlay's picture (what `vorl
    // detect --overlay` draws) is then the frame itself under the caption.
    let (status, bmp) = http_raw(
        &server.web,
        "GET",
        &format!("/api/frame.bmp?v={}", high["version"]),
        None,
        &[],
    );
    assert_eq!(status, 200);
    let shown = image::load_from_memory(&bmp).expect("a BMP").to_luma8();
    let frame = image::open(set.join("frames/f000.png")).expect("f000").to_luma8();
    assert!(shown == frame, "the page's picture is f000 itself");
    let (status, png) = http_raw(&server.web, "GET", "/api/overlay.png", None, &[]);
    assert_eq!(status, 200);
    let overlay = image::load_from_memory(&png).expect("a PNG").to_rgb8();
    assert_eq!(overlay.dimensions(), frame.dimensions());
    let differ = frame
        .enumerate_pixels()
        .filter(|(_, y, _)| *y >= 24)
        .filter(|(x, y, p)| overlay.get_pixel(*x, *y).0 != [p.0[0]; 3])
        .count();
    assert_eq!(
        differ, 0,
        "pixels of the overlay below its caption that are not the frame's"
    );
    // Back down to 60 with Home and the arrow keys (each step applied as the slider moves):
    // the page shows what `vorl detect --threshold 60` gives, which is not the default's.
    let keys: String = std::iter::once(KEY_HOME)
        .chain(std::iter::repeat_n(KEY_RIGHT, 59))
        .collect();
    browser.type_into("#threshold-slider", &keys);
    browser.wait_for(
        "return document.getElementById('threshold-slider').value === '60'
            && document.getElementById('msg').textContent === 'threshold = 60: applied'",
    );
    assert_eq!(server.get("/api/params").1["config"]["threshold"], json!(60));
    let want = detect_json(&set, &["--threshold", "60"]);
    let default = detect_json(&set, &[]);
    assert_ne!(
        want["f000.png"], default["f000.png"],
        "threshold 60 changes f000's parts"
    );
    let mid = server.last_when(|v| v["frames"]["f000.png"] == want["f000.png"]);
    let (parts, points, crosses) = drawn(&mid["version"]);
    let want_crosses: Vec<String> = want["f000.png"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|p| {
                    let at = |k: &str| p[k].as_f64().unwrap_or(f64::NAN).round();
                    format!("{},{}", at("x"), at("y"))
                })
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(parts, want_crosses.len() as u64, "parts drawn again at threshold 60");
    assert!(points > 100, "{points} points");
    assert_eq!(
        crosses, want_crosses,
        "the crosses where detect --threshold 60 puts the parts"
    );
    let (_, shapes) = server.get(&format!("/api/overlay.json?v={}", mid["version"]));
    assert_overlay_matches(&shapes, &want["f000.png"]);
    let want_rows = rows_of(&want["f000.png"]);
    let rows = browser.wait_for(&format!(
        "const rows = {}; return rows.length === {} && rows",
        ROWS.trim_start_matches("return "),
        want_rows.len()
    ));
    assert_eq!(rows, json!(want_rows));
    // The next frames run with it too.
    let (head, lines) = server.robot().ask("TRG");
    assert_eq!(res_frame(&head), "f001.png");
    let want_lines = lines_of(&want["f001.png"]);
    assert_eq!(lines, want_lines);
    drop(browser);
    assert_eq!(server.terminate(), Some(0));
}

/// The threshold in force, as the slider shows it (a string, as an input's value is).
fn before_threshold(server: &Server) -> String {
    let t = &server.get("/api/params").1["config"]["threshold"];
    t.as_u64().map_or_else(|| t.to_string(), |v| v.to_string())
}

#[test]
fn the_page_adds_another_example_of_a_class() {
    let Some(browser) = Browser::start() else {
        return;
    };
    // The washer is not taught; f000 holds two, taught here as examples of one class "ring".
    // (The scratch folder lives to the test's end.)
    let (_dir, set, truth) = plant_without_washer("serve-page-add");
    let washers: Vec<(f64, f64)> = truth["frames"]["f000.png"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter(|p| p["class"] == "washer")
                .map(|p| (p["x"].as_f64().unwrap_or(0.0), p["y"].as_f64().unwrap_or(0.0)))
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(washers.len(), 2, "two washers in f000");
    let server = Server::start(&[set.to_str().unwrap_or_default(), "--trigger"]);
    assert_eq!(res_frame(&server.robot().ask("TRG").0), "f000.png");
    browser.goto(&format!("http://{}/", server.web));
    browser.wait_for("const i = document.getElementById('frame'); return i.complete && i.naturalWidth === 640");
    let k = browser
        .exec("return document.getElementById('frame').getBoundingClientRect().width")
        .as_f64()
        .unwrap_or(640.0)
        / 640.0;
    let teach = |(x, y): (f64, f64), add: bool| -> String {
        browser.exec("document.getElementById('msg').textContent = ''; document.getElementById('tname').value = ''");
        browser.click_at(
            "#frame",
            ((x - 320.0) * k).round() as i64,
            ((y - 240.0) * k).round() as i64,
        );
        browser.wait_for("return document.getElementById('tpoint').textContent.includes(',')");
        browser.type_into("#tname", "ring");
        let ticked = browser.exec("return document.getElementById('tadd').checked") == json!(true);
        if ticked != add {
            browser.click("#tadd");
        }
        browser.click("#teach");
        let msg = browser.wait_for("const m = document.getElementById('msg').textContent; return m.length > 0 && m");
        msg.as_str().unwrap_or_default().to_string()
    };
    let rings = |v: &Value| {
        v["frames"]["f000.png"]
            .as_array()
            .map_or(0, |a| a.iter().filter(|p| p["class"] == "ring").count())
    };
    // The first washer, a class of one example, saved to the set as templates/ring.png.
    let msg = teach(washers[0], false);
    assert!(msg.starts_with("taught ring from f000.png"), "{msg}");
    assert!(!msg.contains("another example"), "{msg}");
    browser.click("#save");
    browser.wait_for("return document.getElementById('msg').textContent.startsWith('saved')");
    assert!(set.join("templates/ring.png").is_file());
    // The second washer under the same name without the box ticked: refused, nothing changed.
    let before = server.last_when(|_| true);
    let msg = teach(washers[1], false);
    assert!(msg.starts_with("teach: ") && msg.contains("--add"), "{msg}");
    assert_eq!(server.last_when(|_| true)["version"], before["version"]);
    // Ticked: another example of the class; the frame on screen is run again with both.
    let msg = teach(washers[1], true);
    assert_eq!(
        msg,
        "taught ring from f000.png (another example): matched from now on; Save writes it to the set"
    );
    let after = server.last_when(|v| v["version"].as_u64() > before["version"].as_u64());
    let (_, params) = server.get("/api/params");
    assert_eq!(
        params["classes"]
            .as_array()
            .map(|c| c.iter().filter(|n| *n == "ring").count()),
        Some(1),
        "one class ring: {params}"
    );
    // Saved: the class is now a folder of two examples, the single file moved into it (and
    // removed from the set), and `vorl detect SET` gives what the page shows.
    browser.click("#save");
    browser.wait_for("return document.getElementById('msg').textContent.startsWith('saved')");
    assert!(
        !set.join("templates/ring.png").exists(),
        "ring.png moved into templates/ring/"
    );
    let examples = std::fs::read_dir(set.join("templates/ring"))
        .map(|d| {
            d.flatten()
                .filter(|e| e.path().extension().is_some_and(|x| x == "png"))
                .count()
        })
        .unwrap_or(0);
    assert_eq!(examples, 2, "templates/ring/ holds both examples");
    let want = detect_json(&set, &[]);
    assert_eq!(after["frames"]["f000.png"], want["f000.png"]);
    assert_eq!(rings(&after), 2, "both washers are rings: {after}");
    let want_rows = rows_of(&want["f000.png"]);
    let rows = browser.wait_for(&format!(
        "const rows = {}; return rows.filter(r => r[0] === 'ring').length === 2 && rows",
        ROWS.trim_start_matches("return ")
    ));
    assert_eq!(rows, json!(want_rows));
    drop(browser);
    assert_eq!(server.terminate(), Some(0));
}

#[test]
fn sigterm_during_the_set_up_still_stops_cleanly() {
    // SIGTERM while the set is being loaded (or right after start): caught, and the server
    // stops as it does later on, exit 0 and its scratch folder gone, not killed by the signal.
    for delay_ms in [30, 150] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_vorl"))
            .args(["serve", plant().to_str().unwrap_or_default(), "--trigger"])
            .args(["--http", "127.0.0.1:0", "--robot", "127.0.0.1:0", "--stop-after", "60"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start vorl serve");
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
        let deadline = Instant::now() + Duration::from_secs(30);
        let status = loop {
            if let Ok(Some(s)) = child.try_wait() {
                break s;
            }
            if Instant::now() > deadline {
                let _ = child.kill();
                panic!("no stop {delay_ms} ms after start");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        assert_eq!(status.code(), Some(0), "SIGTERM {delay_ms} ms after start: {status}");
        let scratch = format!("vorl-serve-{}-", child.id());
        let left = std::fs::read_dir(std::env::temp_dir())
            .map(|d| {
                d.flatten()
                    .filter(|e| e.file_name().to_string_lossy().starts_with(&scratch))
                    .count()
            })
            .unwrap_or(0);
        assert_eq!(left, 0, "the scratch folder is removed");
    }
}
