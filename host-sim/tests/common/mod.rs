//! The harness shared by the integration tests of the `vorl` binary: a temporary folder that
//! removes itself, and one run of the program with its exit code and output.

#![allow(dead_code)] // each test binary uses its own subset

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

use serde_json::Value;

/// A private temporary folder, removed on drop.
pub struct Scratch {
    path: PathBuf,
}

impl Scratch {
    /// A new empty folder under the system's temporary folder, unique to this process and call.
    pub fn new(tag: &str) -> Scratch {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::SeqCst);
        let path = std::env::temp_dir().join(format!("vorl-test-{}-{n}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("create scratch folder");
        Scratch { path }
    }

    /// A path inside the folder.
    pub fn join(&self, p: impl AsRef<Path>) -> PathBuf {
        self.path.join(p)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// What one run of `vorl` gave.
pub struct Out {
    /// Exit code (`None` when killed by a signal).
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
    /// The command line, for messages.
    pub cmd: String,
}

impl Out {
    /// Panics with the whole run unless it exited 0.
    pub fn success(self) -> Out {
        assert_eq!(self.code, Some(0), "{} failed:\n{}", self.cmd, self.dump());
        self.no_panic()
    }

    /// Panics unless it exited with a non-zero status of its own (not a signal).
    pub fn failure(self) -> Out {
        assert!(
            matches!(self.code, Some(c) if c != 0),
            "{} should fail:\n{}",
            self.cmd,
            self.dump()
        );
        self.no_panic()
    }

    /// Panics when stderr shows a Rust panic.
    pub fn no_panic(self) -> Out {
        assert!(
            !self.stderr.contains("panicked"),
            "{} panicked:\n{}",
            self.cmd,
            self.dump()
        );
        self
    }

    /// The stdout as JSON.
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.stdout)
            .unwrap_or_else(|e| panic!("{}: stdout is not JSON ({e}):\n{}", self.cmd, self.dump()))
    }

    /// The whole run, for failure messages.
    pub fn dump(&self) -> String {
        format!(
            "$ {}\nexit {:?}\n--- stdout\n{}\n--- stderr\n{}",
            self.cmd, self.code, self.stdout, self.stderr
        )
    }

    /// The stderr lines that mention `needle`.
    pub fn stderr_lines_with(&self, needle: &str) -> Vec<&str> {
        self.stderr.lines().filter(|l| l.contains(needle)).collect()
    }

    /// The `error:` lines of stderr.
    pub fn errors(&self) -> Vec<&str> {
        self.stderr.lines().filter(|l| l.starts_with("error:")).collect()
    }
}

/// Runs `vorl` with these arguments.
pub fn vorl<I, S>(args: I) -> Out
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(|a| a.as_ref().to_os_string()).collect();
    let cmd = format!(
        "vorl {}",
        args.iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    );
    let out = Command::new(env!("CARGO_BIN_EXE_vorl"))
        .args(&args)
        .output()
        .expect("run vorl");
    Out {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        cmd,
    }
}
