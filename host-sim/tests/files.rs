//! Malformed input files for the `vorl` program (issue 20, item 3): each gives its own one-line
//! `error:` naming the file, a non-zero exit and no panic; in a batch of frames the good ones
//! are still processed.
//!
//! The PNG files are written here by a small encoder of this test's own (stored deflate blocks,
//! any colour type, bit depth, palette, Adam7 interlacing, IDAT split into pieces), so a file
//! can be cut at every chunk boundary or declare any size, independently of the `image` crate
//! that `vorl` reads them with. The scene is a frame of a small generated set (`vorl gen`).
//!
//! Already covered in `cli.rs` and not repeated: a missing frame, a directory and a text file
//! given as a frame, half a PNG, a frame of another size, RGB and 16-bit frames (converted), a
//! truth.json that does not parse, and unknown keys in `--config` files and in a set's
//! `vorl.toml`.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};

use image::GrayImage;
use serde_json::Value;
use vorl_core::library::{crc32, Library};

mod common;
use common::{vorl, Out, Scratch};

// ---------------------------------------------------------------------------------------------
// A PNG encoder of our own
// ---------------------------------------------------------------------------------------------

/// A PNG to write: samples in file order (big-endian for 16 bits), one filter-0 scanline each.
struct Png {
    width: u32,
    height: u32,
    /// PNG colour type: 0 gray, 2 RGB, 3 palette, 4 gray + alpha, 6 RGBA.
    colour: u8,
    /// Bits per sample: 8 or 16.
    depth: u8,
    /// Bytes of one pixel (e.g. 4 for 16-bit gray + alpha).
    pixel_bytes: usize,
    /// Adam7 interlacing.
    interlaced: bool,
    /// The `PLTE` chunk's entries (palette images).
    palette: Vec<[u8; 3]>,
    /// `pixel_bytes` bytes per pixel, row-major.
    pixels: Vec<u8>,
}

impl Png {
    /// An 8-bit gray PNG of `img`.
    fn gray(img: &GrayImage) -> Png {
        Png {
            width: img.width(),
            height: img.height(),
            colour: 0,
            depth: 8,
            pixel_bytes: 1,
            interlaced: false,
            palette: Vec::new(),
            pixels: img.as_raw().clone(),
        }
    }

    /// The raw (unfiltered, filter byte 0) image data: one pass, or the seven Adam7 passes.
    fn raw(&self) -> Vec<u8> {
        let (w, h, b) = (self.width as usize, self.height as usize, self.pixel_bytes);
        let passes: &[(usize, usize, usize, usize)] = if self.interlaced {
            &[
                (0, 0, 8, 8),
                (4, 0, 8, 8),
                (0, 4, 4, 8),
                (2, 0, 4, 4),
                (0, 2, 2, 4),
                (1, 0, 2, 2),
                (0, 1, 1, 2),
            ]
        } else {
            &[(0, 0, 1, 1)]
        };
        let mut out = Vec::new();
        for &(x0, y0, dx, dy) in passes {
            if x0 >= w || y0 >= h {
                continue; // an empty pass has no scanlines at all
            }
            for y in (y0..h).step_by(dy) {
                out.push(0);
                for x in (x0..w).step_by(dx) {
                    out.extend_from_slice(&self.pixels[(y * w + x) * b..(y * w + x + 1) * b]);
                }
            }
        }
        out
    }

    /// The file, its image data split into `IDAT` chunks of at most `idat` bytes, with a `tEXt`
    /// chunk before them.
    fn encode(&self, idat: usize) -> Vec<u8> {
        self.encode_data(idat, &self.raw())
    }

    /// As [`Png::encode`], with this raw image data (of another size, to make a wrong file).
    fn encode_data(&self, idat: usize, raw: &[u8]) -> Vec<u8> {
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&self.width.to_be_bytes());
        ihdr.extend_from_slice(&self.height.to_be_bytes());
        ihdr.extend_from_slice(&[self.depth, self.colour, 0, 0, u8::from(self.interlaced)]);
        chunk(&mut out, b"IHDR", &ihdr);
        if !self.palette.is_empty() {
            chunk(&mut out, b"PLTE", &self.palette.concat());
        }
        chunk(&mut out, b"tEXt", b"Comment\0written by vorl's files test");
        for piece in zlib_stored(raw).chunks(idat.max(1)) {
            chunk(&mut out, b"IDAT", piece);
        }
        chunk(&mut out, b"IEND", &[]);
        out
    }
}

/// Appends one chunk: length, type, data, CRC-32 of type and data (PNG's CRC is the IEEE one).
fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let start = out.len();
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    let crc = crc32(&out[start..]);
    out.extend_from_slice(&crc.to_be_bytes());
}

/// A zlib stream of stored (uncompressed) deflate blocks.
fn zlib_stored(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = if data.is_empty() {
        vec![&[]]
    } else {
        data.chunks(65_535).collect()
    };
    for (i, block) in blocks.iter().enumerate() {
        out.push(u8::from(i + 1 == blocks.len()));
        let len = block.len() as u16;
        out.extend_from_slice(&len.to_le_bytes());
        out.extend_from_slice(&(!len).to_le_bytes());
        out.extend_from_slice(block);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &v in data {
        a = (a + u32::from(v)) % 65_521;
        b = (b + a) % 65_521;
    }
    out.extend_from_slice(&((b << 16) | a).to_be_bytes());
    out
}

/// The offsets where a PNG's chunks end (the first after the signature), the last = its length.
fn chunk_ends(png: &[u8]) -> Vec<usize> {
    let mut ends = vec![8];
    let mut at = 8;
    while at + 8 <= png.len() {
        let len = u32::from_be_bytes(png[at..at + 4].try_into().unwrap()) as usize;
        at += 12 + len;
        ends.push(at);
    }
    assert_eq!(at, png.len(), "chunks do not tile the file");
    ends
}

// ---------------------------------------------------------------------------------------------
// The set and the checks
// ---------------------------------------------------------------------------------------------

/// A small generated set (200×200, seed 3, one frame), shared by the tests that hold it.
struct Set {
    dir: Scratch,
}

impl Set {
    fn root(&self) -> PathBuf {
        self.dir.join("set")
    }
    fn background(&self) -> PathBuf {
        self.root().join("background.png")
    }
    fn templates(&self) -> PathBuf {
        self.root().join("templates")
    }
    fn frame(&self) -> PathBuf {
        self.root().join("frames").join("f000.png")
    }
    fn frame_image(&self) -> GrayImage {
        image::open(self.frame()).expect("frame opens").to_luma8()
    }
}

fn small_set() -> Arc<Set> {
    static SLOT: Mutex<Weak<Set>> = Mutex::new(Weak::new());
    let mut guard = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(set) = guard.upgrade() {
        return set;
    }
    let set = Arc::new(Set {
        dir: Scratch::new("files-set"),
    });
    let root = set.root();
    vorl([
        OsStr::new("gen"),
        root.as_os_str(),
        OsStr::new("--seed"),
        OsStr::new("3"),
        OsStr::new("--frames"),
        OsStr::new("1"),
        OsStr::new("--width"),
        OsStr::new("200"),
        OsStr::new("--height"),
        OsStr::new("200"),
    ])
    .success();
    *guard = Arc::downgrade(&set);
    set
}

/// `vorl detect --json` of these frames against the set's background and templates.
fn detect(set: &Set, frames: &[PathBuf]) -> Out {
    let mut args: Vec<std::ffi::OsString> = vec![
        "detect".into(),
        "--json".into(),
        "--background".into(),
        set.background().into(),
        "--templates".into(),
        set.templates().into(),
    ];
    args.extend(frames.iter().map(|f| f.clone().into_os_string()));
    vorl(args)
}

/// Asserts the one-line error about `name`: exactly one stderr line mentions it, it starts
/// with `error:` and contains every one of `words` (case-insensitive). Returns the line.
fn error_line<'a>(out: &'a Out, name: &str, words: &[&str]) -> &'a str {
    let lines = out.stderr_lines_with(name);
    assert_eq!(
        lines.len(),
        1,
        "expected one stderr line naming {name}:\n{}",
        out.dump()
    );
    let line = lines[0];
    assert!(
        line.starts_with("error:"),
        "not an error line: {line:?}\n{}",
        out.dump()
    );
    for w in words {
        assert!(
            line.to_lowercase().contains(&w.to_lowercase()),
            "the error about {name} does not say {w:?}: {line:?}"
        );
    }
    line
}

/// The parts reported for one frame.
fn parts<'a>(json: &'a Value, frame: &str) -> &'a Vec<Value> {
    json["frames"][frame]
        .as_array()
        .unwrap_or_else(|| panic!("no frame {frame} in {json}"))
}

/// Writes `bytes` as `name` into `dir`.
fn write(dir: &Scratch, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write");
    p
}

// ---------------------------------------------------------------------------------------------
// Images
// ---------------------------------------------------------------------------------------------

/// A zero-byte file, and a real PNG with one byte of its signature changed.
#[test]
fn empty_file_and_wrong_magic() {
    let set = small_set();
    let scratch = Scratch::new("magic");
    let empty = write(&scratch, "empty.png", &[]);
    let mut bytes = std::fs::read(set.frame()).expect("read frame");
    bytes[3] = b'X'; // "\x89PNX…"
    let magic = write(&scratch, "magic.png", &bytes);
    let out = detect(&set, &[empty, set.frame(), magic]).failure();
    error_line(&out, "empty.png", &["empty file", "0 bytes"]);
    error_line(&out, "magic.png", &["not a png", "signature"]);
    assert!(
        !parts(&out.json(), "f000.png").is_empty(),
        "the good frame:\n{}",
        out.dump()
    );
}

/// A real PNG (a tEXt chunk, the image data in four IDAT chunks) cut at every chunk boundary:
/// each cut file is reported truncated on its own line; the whole file gives the frame's parts.
#[test]
fn png_cut_at_every_chunk_boundary_is_truncated() {
    let set = small_set();
    let scratch = Scratch::new("cuts");
    let img = set.frame_image();
    let bytes = Png::gray(&img).encode(img.as_raw().len() / 3);
    let ends = chunk_ends(&bytes);
    // Signature, IHDR, tEXt, four IDAT, IEND.
    assert_eq!(ends.len(), 8, "{ends:?}");
    let mut files = vec![write(&scratch, "whole.png", &bytes)];
    for (i, &end) in ends[..ends.len() - 1].iter().enumerate() {
        files.push(write(&scratch, &format!("cut{i}_at{end}.png"), &bytes[..end]));
    }
    let out = detect(&set, &files).failure();
    for f in &files[1..] {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        error_line(&out, &name, &["truncated png"]);
    }
    assert_eq!(out.errors().len(), files.len() - 1, "{}", out.dump());
    let json = out.json();
    assert_eq!(json["frames"].as_object().map(|o| o.len()), Some(1));
    let original = detect(&set, &[set.frame()]).success().json();
    assert_eq!(
        parts(&json, "whole.png"),
        parts(&original, "f000.png"),
        "our encoder's file"
    );
}

/// A PNG declaring 100 000 × 100 000 pixels is refused from its header, naming the declared
/// size and the limit, before anything of that size is allocated: the run is held to 1 GiB of
/// address space (with `prlimit`), so a buffer of the declared 10¹⁰ bytes could not even be
/// attempted without an abort. Just over each limit is refused too; a side at the limit is read.
#[test]
fn png_declaring_a_huge_size_is_refused_from_its_header() {
    let set = small_set();
    let scratch = Scratch::new("huge");
    let header_only = |w: u32, h: u32| {
        let one = Png::gray(&GrayImage::new(1, 1));
        let png = Png {
            width: w,
            height: h,
            ..Png::gray(&GrayImage::new(1, 1))
        };
        png.encode_data(1 << 16, &one.raw()) // a 1×1 image's data: wrong for the size, never reached
    };
    let huge = write(&scratch, "huge.png", &header_only(100_000, 100_000));
    let wide = write(&scratch, "wide.png", &header_only(16_385, 1));
    let many = write(&scratch, "many.png", &header_only(8_193, 8_192));
    // 16384 × 1: at the side limit, read, then refused as a frame of another size.
    let line = vec![128u8; 16_384];
    let edge_png = Png {
        pixels: line,
        ..Png::gray(&GrayImage::new(16_384, 1))
    };
    let at_limit = write(&scratch, "at_limit.png", &edge_png.encode(1 << 16));
    let files = [huge, wide, many, at_limit];

    let prlimit = Path::new("/usr/bin/prlimit");
    let out = if prlimit.is_file() {
        let mut cmd = std::process::Command::new(prlimit);
        cmd.arg("--as=1073741824").arg(env!("CARGO_BIN_EXE_vorl"));
        cmd.args(["detect", "--json", "--background"]);
        cmd.arg(set.background())
            .arg("--templates")
            .arg(set.templates())
            .args(&files);
        let o = cmd.output().expect("run prlimit vorl");
        Out {
            code: o.status.code(),
            stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
            cmd: "prlimit --as=1073741824 vorl detect …".into(),
        }
    } else {
        println!("no /usr/bin/prlimit: the huge PNG runs without an address-space limit");
        detect(&set, &files)
    }
    .failure();
    let refused = ["too large", "16384 px a side", "67108864 pixels"];
    let l = error_line(&out, "huge.png", &refused);
    assert!(l.contains("100000×100000"), "the declared size is not named: {l}");
    assert!(error_line(&out, "wide.png", &refused).contains("16385×1"));
    assert!(error_line(&out, "many.png", &refused).contains("8193×8192"));
    error_line(&out, "at_limit.png", &["16384×1", "background"]);

    // GIF (logical screen, 16-bit sizes) and BMP (info header) declare their size too.
    let mut gif = b"GIF89a".to_vec();
    gif.extend_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0]);
    let mut bmp = b"BM".to_vec();
    bmp.extend_from_slice(&[0; 12]);
    bmp.extend_from_slice(&40u32.to_le_bytes());
    bmp.extend_from_slice(&100_000i32.to_le_bytes());
    bmp.extend_from_slice(&(-100_000i32).to_le_bytes()); // top-down rows
    bmp.extend_from_slice(&[1, 0, 8, 0]);
    for (name, bytes, size) in [("huge.gif", gif, "65535×65535"), ("huge.bmp", bmp, "100000×100000")] {
        let p = write(&scratch, name, &bytes);
        let e = vorl_host_sim::io::load_gray(&p).expect_err(name).to_string();
        assert!(e.contains(size) && e.contains("too large"), "{name}: {e}");
    }
}

/// 16-bit gray, palette, Adam7-interlaced, gray + alpha (and interlaced 16-bit gray + alpha)
/// PNGs of a frame are accepted and read as exactly the 8-bit gray frame (16 bits: `v·257`,
/// the exact image of `v`; a palette of grays; any alpha, which is ignored), with a note naming
/// the conversion (none for interlacing, which changes no pixel value); `vorl detect` gives
/// them exactly the original's parts.
#[test]
fn other_png_formats_read_as_the_gray_equivalent() {
    let set = small_set();
    let scratch = Scratch::new("formats");
    let img = set.frame_image();
    let base = Png::gray(&img);
    let alpha = |i: usize| (i * 37 % 256) as u8;
    let deep: Vec<u8> = img
        .as_raw()
        .iter()
        .flat_map(|&v| (u16::from(v) * 257).to_be_bytes())
        .collect();
    let deep_alpha: Vec<u8> = img
        .as_raw()
        .iter()
        .enumerate()
        .flat_map(|(i, &v)| {
            let mut px = (u16::from(v) * 257).to_be_bytes().to_vec();
            px.extend_from_slice(&[alpha(i), 0]);
            px
        })
        .collect();
    // Palette index = 255 − value, so the indices are not themselves the grays.
    let palette: Vec<[u8; 3]> = (0..=255u8).map(|i| [255 - i; 3]).collect();
    let variants: Vec<(&str, Png, Option<&str>)> = vec![
        (
            "deep16.png",
            Png {
                depth: 16,
                pixel_bytes: 2,
                pixels: deep,
                ..Png::gray(&img)
            },
            Some("16-bit gray"),
        ),
        (
            "palette.png",
            Png {
                colour: 3,
                palette,
                pixels: img.as_raw().iter().map(|&v| 255 - v).collect(),
                ..Png::gray(&img)
            },
            Some("palette"),
        ),
        (
            "interlaced.png",
            Png {
                interlaced: true,
                ..Png::gray(&img)
            },
            None,
        ),
        (
            "gray_alpha.png",
            Png {
                colour: 4,
                pixel_bytes: 2,
                pixels: img
                    .as_raw()
                    .iter()
                    .enumerate()
                    .flat_map(|(i, &v)| [v, alpha(i)])
                    .collect(),
                ..Png::gray(&img)
            },
            Some("gray with alpha (alpha ignored)"),
        ),
        (
            "interlaced_gray_alpha16.png",
            Png {
                colour: 4,
                depth: 16,
                pixel_bytes: 4,
                interlaced: true,
                pixels: deep_alpha,
                ..Png::gray(&img)
            },
            Some("16-bit gray with alpha"),
        ),
    ];
    let mut files = vec![write(&scratch, "plain.png", &base.encode(1 << 20))];
    for (name, png, note) in &variants {
        let p = write(&scratch, name, &png.encode(1 << 20));
        let loaded = vorl_host_sim::io::load_gray(&p).unwrap_or_else(|e| panic!("{e}"));
        assert!(loaded.image == img, "{name}: not the 8-bit gray frame");
        match note {
            Some(n) => assert!(
                loaded.note.as_deref().is_some_and(|t| t.contains(n)),
                "{name}: note {:?}",
                loaded.note
            ),
            None => assert_eq!(loaded.note, None, "{name}"),
        }
        files.push(p);
    }
    let out = detect(&set, &files).success();
    let json = out.json();
    let plain = parts(&json, "plain.png");
    assert!(!plain.is_empty());
    for (name, _, note) in &variants {
        assert_eq!(parts(&json, name), plain, "{name}: parts differ from the gray frame's");
        let noted = out
            .stderr_lines_with(name)
            .iter()
            .any(|l| l.starts_with("note:") && l.contains("converted"));
        assert_eq!(noted, note.is_some(), "{name}: conversion note\n{}", out.dump());
    }
}

/// 16-bit values that are not multiples of 257 are read as the nearest 8-bit value.
#[test]
fn sixteen_bit_gray_is_rounded_to_the_nearest_8_bit_value() {
    let scratch = Scratch::new("round16");
    let values: Vec<u16> = (0..=255u16)
        .flat_map(|v| [v * 257, (v * 257).saturating_add(128), (v * 257).saturating_sub(128)])
        .collect();
    let png = Png {
        width: values.len() as u32,
        height: 1,
        colour: 0,
        depth: 16,
        pixel_bytes: 2,
        interlaced: false,
        palette: Vec::new(),
        pixels: values.iter().flat_map(|v| v.to_be_bytes()).collect(),
    };
    let p = write(&scratch, "ramp16.png", &png.encode(1 << 20));
    let loaded = vorl_host_sim::io::load_gray(&p).expect("loads");
    for (i, &v) in values.iter().enumerate() {
        let want = (f64::from(v) / 257.0).round() as u8;
        let got = loaded.image.get_pixel(i as u32, 0).0[0];
        assert_eq!(got, want, "{v} read as {got}");
    }
}

// ---------------------------------------------------------------------------------------------
// Files that are not files, or not readable
// ---------------------------------------------------------------------------------------------

/// A directory where a set's file, a `--config` file or a template library is expected is
/// refused by name (not silently taken as "no such file": a set with a directory
/// background.png would otherwise have its platform estimated instead).
#[test]
fn directory_where_a_file_is_expected() {
    let set = small_set();
    let scratch = Scratch::new("dirs");
    let root = scratch.join("set");
    for (name, cmd) in [
        ("background.png", "detect"),
        ("truth.json", "eval"),
        ("vorl.toml", "detect"),
    ] {
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("frames")).expect("mkdir");
        std::fs::copy(set.frame(), root.join("frames/f000.png")).expect("copy");
        for f in ["background.png", "truth.json"] {
            std::fs::copy(set.root().join(f), root.join(f)).expect("copy");
        }
        std::fs::create_dir_all(root.join("templates")).expect("mkdir");
        std::fs::copy(set.templates().join("washer.png"), root.join("templates/washer.png")).expect("copy");
        let _ = std::fs::remove_file(root.join(name));
        std::fs::create_dir_all(root.join(name)).expect("mkdir");
        let out = vorl([OsStr::new(cmd), root.as_os_str()]).failure();
        error_line(&out, name, &["is a directory"]);
    }
    let folder = scratch.join("folder.vtl");
    std::fs::create_dir_all(&folder).expect("mkdir");
    let out = vorl([OsStr::new("templates"), OsStr::new("info"), folder.as_os_str()]).failure();
    error_line(&out, "folder.vtl", &["is a directory"]);
    let out = vorl([
        OsStr::new("detect"),
        set.root().as_os_str(),
        OsStr::new("--config"),
        folder.as_os_str(),
    ])
    .failure();
    error_line(&out, "folder.vtl", &["is a directory"]);
}

/// The effective user id, from /proc/self/status (Linux).
fn effective_uid() -> Option<u32> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("Uid:"))?;
    line.split_whitespace().nth(2)?.parse().ok()
}

/// A frame without read permission (mode 000) is "permission denied". Root reads any file
/// whatever its mode, so as root the program is run as the user `nobody` (uid 65534, with
/// `setpriv`); where that is not possible the test says so and checks nothing.
#[test]
fn frame_without_read_permission() {
    use std::os::unix::fs::PermissionsExt;
    let set = small_set();
    let scratch = Scratch::new("perm");
    let locked = scratch.join("locked.png");
    std::fs::copy(set.frame(), &locked).expect("copy");
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o000)).expect("chmod");
    let args = |cmd: &mut std::process::Command| {
        cmd.args(["detect", "--json", "--background"])
            .arg(set.background())
            .arg("--templates")
            .arg(set.templates())
            .arg(set.frame())
            .arg(&locked);
    };
    let mut cmd = if effective_uid() == Some(0) {
        let setpriv = Path::new("/usr/bin/setpriv");
        if !setpriv.is_file() {
            println!("skipped: running as root (mode 000 still reads) and no /usr/bin/setpriv to drop to nobody");
            return;
        }
        let mut c = std::process::Command::new(setpriv);
        c.args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"]);
        c.arg(env!("CARGO_BIN_EXE_vorl"));
        c
    } else {
        std::process::Command::new(env!("CARGO_BIN_EXE_vorl"))
    };
    args(&mut cmd);
    let o = cmd.output().expect("run vorl");
    let out = Out {
        code: o.status.code(),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        cmd: format!("{cmd:?}"),
    };
    if effective_uid() == Some(0) && out.stderr_lines_with("locked.png").is_empty() {
        // nobody could not run the program or read the set (e.g. the build folder is private).
        println!("skipped: as nobody the program did not run on the set:\n{}", out.dump());
        return;
    }
    let out = out.failure();
    error_line(&out, "locked.png", &["permission denied"]);
    assert!(!parts(&out.json(), "f000.png").is_empty(), "{}", out.dump());
}

// ---------------------------------------------------------------------------------------------
// Template library, truth
// ---------------------------------------------------------------------------------------------

/// A template library whose CRC is right but whose template count disagrees with its payload
/// (one record more, one fewer than the records there) is refused by the core's parser with a
/// typed `Corrupt` error, which `vorl templates info` prints as one line naming the file.
#[test]
fn library_with_a_valid_crc_but_inconsistent_counts() {
    let set = small_set();
    let scratch = Scratch::new("library");
    let good = scratch.join("good.vtl");
    vorl([
        OsStr::new("templates"),
        OsStr::new("export"),
        set.templates().as_os_str(),
        OsStr::new("--out"),
        good.as_os_str(),
    ])
    .success();
    vorl([OsStr::new("templates"), OsStr::new("info"), good.as_os_str()]).success();
    let bytes = std::fs::read(&good).expect("read library");
    let count = u16::from_le_bytes([bytes[22], bytes[23]]);
    assert!(count >= 2, "{count}");
    for (name, t) in [("more.vtl", count + 1), ("fewer.vtl", count - 1)] {
        let mut b = bytes.clone();
        b[22..24].copy_from_slice(&t.to_le_bytes());
        let crc = crc32(&b[16..]);
        b[12..16].copy_from_slice(&crc.to_le_bytes());
        assert!(
            matches!(Library::parse(&b), Err(vorl_core::Error::Corrupt { .. })),
            "{name}: {:?}",
            Library::parse(&b).map(|l| l.len())
        );
        let p = write(&scratch, name, &b);
        let out = vorl([OsStr::new("templates"), OsStr::new("info"), p.as_os_str()]).failure();
        error_line(&out, name, &["template count"]);
        assert!(out.stdout.is_empty(), "{}", out.dump());
    }
}

/// A truth.json of the right JSON syntax but with values of the wrong type is refused by `vorl
/// eval` on one line naming the file and the wrong type.
#[test]
fn truth_with_wrong_types() {
    let set = small_set();
    let scratch = Scratch::new("truthtypes");
    let root = scratch.join("set");
    std::fs::create_dir_all(root.join("frames")).expect("mkdir");
    std::fs::create_dir_all(root.join("templates")).expect("mkdir");
    std::fs::copy(set.frame(), root.join("frames/f000.png")).expect("copy");
    std::fs::copy(set.background(), root.join("background.png")).expect("copy");
    std::fs::copy(set.templates().join("washer.png"), root.join("templates/washer.png")).expect("copy");
    let part = |x: &str, class: &str| {
        format!(r#"{{"frames": {{"f000.png": [{{"class": {class}, "x": {x}, "y": 10, "angle_deg": 0}}]}}}}"#)
    };
    for (json, wrong) in [
        (part("\"12.5\"", "\"washer\""), "string"),
        (part("12.5", "7"), "integer"),
        (r#"{"frames": [1, 2]}"#.to_string(), "sequence"),
        (r#"{"frames": {"f000.png": {"class": null}}}"#.to_string(), "map"),
    ] {
        std::fs::write(root.join("truth.json"), &json).expect("write");
        let out = vorl([OsStr::new("eval"), root.as_os_str()]).failure();
        error_line(&out, "truth.json", &["invalid type", wrong]);
    }
}
