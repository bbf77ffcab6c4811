//! Template libraries: the taught templates as one compact, versioned, checksummed byte block.
//!
//! A camera is not taught in the field: the templates are made on a host from silhouettes
//! (`vorl templates export DIR --out FILE`), written as a library file, and the file is put into
//! the camera's flash (`include_bytes!`) or loaded from storage. [`Library::parse`] checks the
//! whole block before anything is used, so a flipped bit, a cut-off download or a file of another
//! version is an [`Error`], never a wrong template; [`Recognizer::load_library`](crate::Recognizer::load_library) then fills a
//! [`Recognizer`](crate::Recognizer) without any allocation. [`write_library`] writes the format into a caller's
//! buffer of [`encoded_len`] bytes.
//!
//! # Format, version 2
//!
//! Little-endian throughout; every real value is an IEEE-754 `f32`. A 16-byte header, then the
//! payload: the parameters the templates were made with, then one fixed-size record per template.
//! Version 2 adds each template's holes ([`crate::pose::holes`]) at the end of its record; libraries
//! of version 1 (the same records without the holes) are still read, their templates without
//! holes.
//!
//! | offset | bytes | field |
//! |---:|---:|---|
//! | 0 | 4 | magic `VRLT` (`56 52 4C 54`) |
//! | 4 | 2 | format version, `u16` = [`VERSION`] (2; 1 is read too) |
//! | 6 | 2 | reserved, `u16` = 0 |
//! | 8 | 4 | payload length `L` in bytes, `u32` (everything after the header) |
//! | 12 | 4 | CRC-32 of the `L` payload bytes, `u32` ([`crc32`]: IEEE 802.3, reflected, polynomial `0xEDB88320`) |
//! | 16 | 2 | `n`, points of a part contour, `u16` |
//! | 18 | 2 | `m`, points of every template, `u16` (`n ≤ m < 2n`) |
//! | 20 | 2 | `k`, neighbourhood of the angle term for parts, `u16` (`1 ≤ k`, `2k < n`) |
//! | 22 | 2 | `T`, number of templates, `u16` |
//! | 24 | 4 | `ω`, weight of the angle term, `f32` in `[0, 1]` |
//! | 28 | `T·(172 + 28·m)` | `T` template records, below |
//!
//! One template record ([`record_len`]`(m) = 172 + 28·m` bytes, at `28 + i·record_len(m)`;
//! in version 1, `60 + 28·m` bytes: the same without the holes and the tolerance):
//!
//! | offset | bytes | field |
//! |---:|---:|---|
//! | +0 | 1 | length of the class name in bytes, `u8` ≤ [`MAX_NAME_LEN`] (31) |
//! | +1 | 31 | the class name, UTF-8, zero-padded |
//! | +32 | 8 | `C'`, mean of the resampled points: x, y |
//! | +40 | 8 | area centroid of the silhouette: x, y |
//! | +48 | 4 | polygon area of the border, px² |
//! | +52 | 8 | the part's position (the silhouette's pixel centroid) as an offset from the area centroid: x, y |
//! | +60 | `8·m` | the `m` resampled points: x₀, y₀, x₁, y₁, … |
//! | +60 + 8·m | `4·m` | the `m` descriptor values `c'_j` |
//! | +60 + 12·m | `8·m` | the `m` sub-pixel edge points, offsets from the area centroid: x, y, … |
//! | +60 + 20·m | `8·m` | the `m` unit outward normals at the edge points: x, y, … |
//! | +60 + 28·m | 4 | number of holes `h`, `u32` ≤ [`MAX_HOLES`] (8) |
//! | +64 + 28·m | 96 | 8 holes, largest first: centre as an offset from the area centroid x, y, and area in px², `f32`; the slots after the first `h` are 0 |
//! | +160 + 28·m | 12 | the class's [`Tolerance`]: factor on the verification limit (≥ [`Tolerance::MIN_VERIFY`], 0.5), scale range low (≤ 1) and high (≥ 1), `f32`; 1, 1, 1 for a single-example class |
//!
//! So `L = 12 + T·(172 + 28·m)` exactly, and the file is `16 + L` bytes ([`encoded_len`]); for
//! 8 templates of `m = 96` points that is 22 908 bytes. A template read back is equal, field for
//! field, to the one that was written (`Template`'s `PartialEq`).
//!
//! # Checks, in order
//!
//! | problem | error |
//! |---|---|
//! | fewer than 16 bytes | [`Error::Truncated`] |
//! | first four bytes are not `VRLT` | [`Error::BadMagic`] |
//! | version is not 1 or 2 | [`Error::UnsupportedVersion`] |
//! | fewer than `16 + L` bytes | [`Error::Truncated`] |
//! | CRC-32 of the payload differs from the stored one | [`Error::Checksum`] |
//! | reserved field not 0, bytes after the payload, `L` not `12 + T·record_len(m)`, parameters out of range, a name too long or not UTF-8, a value not finite, more than 8 holes or a hole of no area, a tolerance out of range | [`Error::Corrupt`] |
//!
//! ```
//! use vorl_core::library::{encoded_len, write_library, Library};
//! use vorl_core::{Params, Template};
//! // A template made from a 12×8 rectangle's border.
//! let mut border = Vec::new();
//! for y in 0..8u16 { border.push(vorl_core::borders::contour::Point { x: 0, y }); }
//! for x in 0..12u16 { border.push(vorl_core::borders::contour::Point { x, y: 8 }); }
//! for y in (1..=8u16).rev() { border.push(vorl_core::borders::contour::Point { x: 12, y }); }
//! for x in (1..=12u16).rev() { border.push(vorl_core::borders::contour::Point { x, y: 0 }); }
//! let params = Params::DEFAULT;
//! let t = Template::<96>::from_border(&border, core::iter::empty(), &params).unwrap();
//! let mut bytes = vec![0u8; encoded_len(1, params.m)];
//! write_library(&mut bytes, &params, [("plate", &t)]).unwrap();
//! let lib = Library::parse(&bytes).unwrap();
//! assert_eq!((lib.len(), lib.n(), lib.m()), (1, 64, 96));
//! assert_eq!(lib.name(0), Some("plate"));
//! assert_eq!(lib.template::<96>(0).unwrap(), t);
//! bytes[40] ^= 1; // one flipped bit
//! assert!(matches!(Library::parse(&bytes), Err(vorl_core::Error::Checksum { .. })));
//! ```

use crate::borders::resample::check_counts;
use crate::error::{Error, Result};
use crate::library::template::{Template, Tolerance};
use crate::params::Params;
use crate::pose::holes::{Hole, Holes, MAX_HOLES};

pub mod template;

/// The four bytes a library starts with.
pub const MAGIC: [u8; 4] = *b"VRLT";
/// The format version this core writes (it reads 1 too).
pub const VERSION: u16 = 2;
/// Bytes of the header (magic, version, reserved, payload length, CRC-32).
pub const HEADER_LEN: usize = 16;
/// Bytes of the parameter block at the start of the payload (`n`, `m`, `k`, `T`, `ω`).
pub const PARAMS_LEN: usize = 12;
/// Bytes of a record's name field (length byte and the padded name).
pub const NAME_FIELD_LEN: usize = 32;
/// Longest class name in bytes.
pub const MAX_NAME_LEN: usize = NAME_FIELD_LEN - 1;
/// Bytes of a record before its points: name field, centroid, area centroid, area, position.
const RECORD_HEAD_LEN: usize = NAME_FIELD_LEN + 28;

/// Bytes of a record's hole block (the count and [`MAX_HOLES`] slots of three `f32`) and its
/// tolerance (three `f32`).
const HOLES_LEN: usize = 4 + 12 * MAX_HOLES + 12;

/// Bytes of one template record with `m` points: `172 + 28·m` (saturating at `usize::MAX`).
pub const fn record_len(m: usize) -> usize {
    record_len_of(VERSION, m)
}

/// Bytes of one record of format `version` (1: `60 + 28·m`, without the holes).
const fn record_len_of(version: u16, m: usize) -> usize {
    let points = m.saturating_mul(28).saturating_add(RECORD_HEAD_LEN);
    if version >= 2 {
        points.saturating_add(HOLES_LEN)
    } else {
        points
    }
}

/// Bytes of a whole library of `templates` templates of `m` points: `28 + T·(172 + 28·m)`
/// (saturating at `usize::MAX`).
pub const fn encoded_len(templates: usize, m: usize) -> usize {
    encoded_len_of(VERSION, templates, m)
}

const fn encoded_len_of(version: u16, templates: usize, m: usize) -> usize {
    templates
        .saturating_mul(record_len_of(version, m))
        .saturating_add(HEADER_LEN + PARAMS_LEN)
}

/// The CRC-32 lookup table (IEEE 802.3, reflected, polynomial `0xEDB88320`), made at compile time.
const CRC_TABLE: [u32; 256] = crc_table();

const fn crc_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut bit = 0;
        while bit < 8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            bit += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

/// The CRC-32 of `data` (IEEE 802.3 / zlib / PNG: reflected, polynomial `0xEDB88320`, initial
/// value and final XOR `0xFFFFFFFF`), one table lookup per byte.
///
/// ```
/// assert_eq!(vorl_core::library::crc32(b"123456789"), 0xCBF4_3926);
/// ```
pub fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        let index = ((c ^ b as u32) & 0xFF) as usize;
        c = CRC_TABLE.get(index).copied().unwrap_or(0) ^ (c >> 8);
    }
    !c
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    let b = bytes.get(at..at + 2)?;
    Some(u16::from_le_bytes([*b.first()?, *b.get(1)?]))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at + 4)?;
    Some(u32::from_le_bytes([*b.first()?, *b.get(1)?, *b.get(2)?, *b.get(3)?]))
}

fn f32_at(bytes: &[u8], at: usize) -> Option<f32> {
    u32_at(bytes, at).map(f32::from_bits)
}

/// A checked template library borrowed from its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Library<'a> {
    /// The records, `T·record_len(m)` bytes (of the library's version).
    records: &'a [u8],
    /// The format version (1 or 2).
    version: u16,
    n: usize,
    m: usize,
    k: usize,
    count: usize,
    omega: f32,
    checksum: u32,
}

impl<'a> Library<'a> {
    /// Checks every byte of a library (see the module's table of checks) and borrows it.
    ///
    /// # Errors
    /// [`Error::Truncated`], [`Error::BadMagic`], [`Error::UnsupportedVersion`],
    /// [`Error::Checksum`] or [`Error::Corrupt`], in the order of the module's table.
    pub fn parse(bytes: &'a [u8]) -> Result<Self> {
        let truncated = |needed: usize| Error::Truncated {
            needed,
            got: bytes.len(),
        };
        let header = bytes.get(..HEADER_LEN).ok_or(truncated(HEADER_LEN))?;
        if header.get(..4) != Some(&MAGIC[..]) {
            return Err(Error::BadMagic);
        }
        let version = u16_at(header, 4).ok_or(truncated(HEADER_LEN))?;
        if version != VERSION && version != 1 {
            return Err(Error::UnsupportedVersion {
                found: version,
                supported: VERSION,
            });
        }
        let reserved = u16_at(header, 6).ok_or(truncated(HEADER_LEN))?;
        let payload_len = u32_at(header, 8).ok_or(truncated(HEADER_LEN))? as usize;
        let stored = u32_at(header, 12).ok_or(truncated(HEADER_LEN))?;
        let total = HEADER_LEN
            .checked_add(payload_len)
            .ok_or(Error::Corrupt { what: "payload length" })?;
        let payload = bytes.get(HEADER_LEN..total).ok_or(truncated(total))?;
        let computed = crc32(payload);
        if computed != stored {
            return Err(Error::Checksum { stored, computed });
        }
        if reserved != 0 {
            return Err(Error::Corrupt {
                what: "reserved header field is not 0",
            });
        }
        if bytes.len() != total {
            return Err(Error::Corrupt {
                what: "bytes after the payload",
            });
        }
        let field = |at: usize| {
            u16_at(payload, at).map(usize::from).ok_or(Error::Corrupt {
                what: "payload shorter than the parameter block",
            })
        };
        let (n, m, k, count) = (field(0)?, field(2)?, field(4)?, field(6)?);
        let omega = f32_at(payload, 8).ok_or(Error::Corrupt {
            what: "payload shorter than the parameter block",
        })?;
        if check_counts(n, m).is_err() {
            return Err(Error::Corrupt {
                what: "point counts break n ≤ m < 2n",
            });
        }
        if k == 0 || 2 * k >= n {
            return Err(Error::Corrupt {
                what: "neighbourhood k out of range (1 ≤ k, 2k < n)",
            });
        }
        if !(0.0..=1.0).contains(&omega) {
            return Err(Error::Corrupt {
                what: "ω out of [0, 1]",
            });
        }
        if HEADER_LEN.checked_add(payload_len) != Some(encoded_len_of(version, count, m)) {
            return Err(Error::Corrupt {
                what: "payload length does not match the template count and m",
            });
        }
        let records = payload.get(PARAMS_LEN..).unwrap_or(&[]);
        for record in records.chunks_exact(record_len_of(version, m)) {
            check_record(record, m)?;
        }
        Ok(Library {
            records,
            version,
            n,
            m,
            k,
            count,
            omega,
            checksum: stored,
        })
    }

    /// Points of a part contour, `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Points of every template, `m`.
    pub fn m(&self) -> usize {
        self.m
    }

    /// Neighbourhood of the angle term for parts, `k`.
    pub fn k(&self) -> usize {
        self.k
    }

    /// Weight of the angle term, `ω`.
    pub fn omega(&self) -> f32 {
        self.omega
    }

    /// Number of templates.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether the library holds no template.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The stored CRC-32 of the payload (an identifier of the library's content).
    pub fn checksum(&self) -> u32 {
        self.checksum
    }

    /// `base` with the library's `n`, `m`, `k` and `ω`: the parameters the templates need.
    pub fn params(&self, base: Params) -> Params {
        Params {
            n: self.n,
            m: self.m,
            k: self.k,
            omega: self.omega,
            ..base
        }
    }

    fn record(&self, index: usize) -> Option<&'a [u8]> {
        if index >= self.count {
            return None;
        }
        let len = record_len_of(self.version, self.m);
        let start = index.checked_mul(len)?;
        self.records.get(start..start.checked_add(len)?)
    }

    /// The class name of template `index` (`None` past the end).
    pub fn name(&self, index: usize) -> Option<&'a str> {
        self.record(index).and_then(record_name)
    }

    /// Template `index`, decoded into a [`Template`] of capacity `M`.
    ///
    /// # Errors
    /// [`Error::Capacity`] when `index` is past the end or `m > M`.
    pub fn template<const M: usize>(&self, index: usize) -> Result<Template<M>> {
        let record = self.record(index).ok_or(Error::Capacity {
            what: "library templates",
            capacity: self.count,
            requested: index.saturating_add(1),
        })?;
        if self.m > M {
            return Err(Error::Capacity {
                what: "template points M",
                capacity: M,
                requested: self.m,
            });
        }
        let f = |at: usize| f32_at(record, at).unwrap_or(f32::NAN);
        let pair = |at: usize| [f(at), f(at + 4)];
        let m = self.m;
        let (points_at, descriptor_at) = (RECORD_HEAD_LEN, RECORD_HEAD_LEN + 8 * m);
        let (edge_at, normals_at) = (RECORD_HEAD_LEN + 12 * m, RECORD_HEAD_LEN + 20 * m);
        let points = (0..m).map(|j| pair(points_at + 8 * j));
        let descriptor = (0..m).map(|j| f(descriptor_at + 4 * j));
        let mut t = Template::from_parts(points, descriptor, pair(32), pair(40), f(48))?;
        let mut edge = [[0.0f32; 2]; M];
        let mut normals = [[0.0f32; 2]; M];
        for (j, (e, n)) in edge.iter_mut().zip(normals.iter_mut()).take(m).enumerate() {
            *e = pair(edge_at + 8 * j);
            *n = pair(normals_at + 8 * j);
        }
        t.set_edge(edge.get(..m).unwrap_or(&[]), normals.get(..m).unwrap_or(&[]), pair(52))?;
        if self.version >= 2 {
            let holes_at = RECORD_HEAD_LEN + 28 * m;
            let count = u32_at(record, holes_at).unwrap_or(0) as usize;
            let mut holes = Holes::new();
            for j in 0..count.min(MAX_HOLES) {
                let at = holes_at + 4 + 12 * j;
                holes.insert(Hole {
                    centre: pair(at),
                    area: f(at + 8),
                });
            }
            t.set_holes(holes);
            let at = holes_at + 4 + 12 * MAX_HOLES;
            t.set_tolerance(Tolerance {
                verify: f(at),
                scale: pair(at + 4),
            })?;
        }
        Ok(t)
    }
}

fn record_name(record: &[u8]) -> Option<&str> {
    let len = usize::from(*record.first()?);
    core::str::from_utf8(record.get(1..1 + len)?).ok()
}

fn check_record(record: &[u8], m: usize) -> Result<()> {
    let len = usize::from(record.first().copied().unwrap_or(0));
    if len > MAX_NAME_LEN {
        return Err(Error::Corrupt {
            what: "template name longer than 31 bytes",
        });
    }
    if record_name(record).is_none() {
        return Err(Error::Corrupt {
            what: "template name is not UTF-8",
        });
    }
    let padding = record.get(1 + len..NAME_FIELD_LEN).unwrap_or(&[]);
    if padding.iter().any(|&b| b != 0) {
        return Err(Error::Corrupt {
            what: "template name padding is not zero",
        });
    }
    let holes_at = RECORD_HEAD_LEN + 28 * m;
    let values = record.get(NAME_FIELD_LEN..holes_at).unwrap_or(&[]);
    let hole_values = record.get(holes_at + 4..).unwrap_or(&[]);
    for v in values.chunks_exact(4).chain(hole_values.chunks_exact(4)) {
        if !f32_at(v, 0).is_some_and(f32::is_finite) {
            return Err(Error::Corrupt {
                what: "template value is not finite",
            });
        }
    }
    // Version 2's hole block (a version 1 record ends before it).
    if let Some(count) = u32_at(record, holes_at) {
        if count as usize > MAX_HOLES {
            return Err(Error::Corrupt {
                what: "template hole count over 8",
            });
        }
        for j in 0..count as usize {
            if !f32_at(hole_values, 12 * j + 8).is_some_and(|a| a > 0.0) {
                return Err(Error::Corrupt {
                    what: "template hole of no area",
                });
            }
        }
        let at = 12 * MAX_HOLES;
        let tolerance = Tolerance {
            verify: f32_at(hole_values, at).unwrap_or(f32::NAN),
            scale: [
                f32_at(hole_values, at + 4).unwrap_or(f32::NAN),
                f32_at(hole_values, at + 8).unwrap_or(f32::NAN),
            ],
        };
        if !tolerance.is_valid() {
            return Err(Error::Corrupt {
                what: "template tolerance out of range",
            });
        }
    }
    Ok(())
}

/// Writes a library of `templates` (class name and template, all of `params.m` points) made with
/// `params` into `out`; returns the bytes written ([`encoded_len`]).
///
/// # Errors
/// [`Error::BufferTooSmall`] when `out` is shorter than the library; [`Error::PointCounts`] for a
/// template whose point count is not `params.m`; [`Error::Capacity`] for a name longer than
/// [`MAX_NAME_LEN`] bytes or more than 65 535 templates; [`Params::validate`]'s errors.
pub fn write_library<'t, const M: usize>(
    out: &mut [u8],
    params: &Params,
    templates: impl IntoIterator<Item = (&'t str, &'t Template<M>)>,
) -> Result<usize> {
    params.validate()?;
    let (n, m) = (params.n, params.m);
    let too_big = |what, requested| Error::Capacity {
        what,
        capacity: u16::MAX as usize,
        requested,
    };
    let n16 = u16::try_from(n).map_err(|_| too_big("n", n))?;
    let m16 = u16::try_from(m).map_err(|_| too_big("m", m))?;
    let k16 = u16::try_from(params.k).map_err(|_| too_big("k", params.k))?;
    let rlen = record_len(m);
    let mut count = 0usize;
    let mut at = HEADER_LEN + PARAMS_LEN;
    for (name, t) in templates {
        if t.len() != m {
            return Err(Error::PointCounts { n, m: t.len() });
        }
        if name.len() > MAX_NAME_LEN {
            return Err(Error::Capacity {
                what: "template name bytes",
                capacity: MAX_NAME_LEN,
                requested: name.len(),
            });
        }
        let got = out.len();
        let end = at.saturating_add(rlen);
        let record = out.get_mut(at..end).ok_or(Error::BufferTooSmall { needed: end, got })?;
        record.fill(0);
        let mut w = Writer { buf: record, at: 0 };
        w.bytes(&[name.len() as u8]);
        w.bytes(name.as_bytes());
        w.at = NAME_FIELD_LEN;
        for v in t
            .centroid()
            .into_iter()
            .chain(t.area_centroid())
            .chain([t.area()])
            .chain(t.position_offset())
        {
            w.f32(v);
        }
        for p in t.points() {
            w.f32(p[0]);
            w.f32(p[1]);
        }
        for &c in t.descriptor() {
            w.f32(c);
        }
        for p in t.edge().iter().chain(t.normals()) {
            w.f32(p[0]);
            w.f32(p[1]);
        }
        let holes = t.holes().as_slice();
        w.bytes(&(holes.len() as u32).to_le_bytes());
        for h in holes {
            w.f32(h.centre[0]);
            w.f32(h.centre[1]);
            w.f32(h.area);
        }
        w.at = RECORD_HEAD_LEN + 28 * m + 4 + 12 * MAX_HOLES;
        let tolerance = t.tolerance();
        for v in [tolerance.verify, tolerance.scale[0], tolerance.scale[1]] {
            w.f32(v);
        }
        count += 1;
        at = end;
    }
    let count16 = u16::try_from(count).map_err(|_| too_big("templates", count))?;
    let total = encoded_len(count, m);
    let got = out.len();
    let lib = out
        .get_mut(..total)
        .ok_or(Error::BufferTooSmall { needed: total, got })?;
    let payload_len = u32::try_from(total.saturating_sub(HEADER_LEN)).map_err(|_| Error::Capacity {
        what: "library bytes",
        capacity: u32::MAX as usize,
        requested: total,
    })?;
    let (header, payload) = lib
        .split_at_mut_checked(HEADER_LEN)
        .ok_or(Error::BufferTooSmall { needed: total, got })?;
    let mut w = Writer { buf: payload, at: 0 };
    w.bytes(&n16.to_le_bytes());
    w.bytes(&m16.to_le_bytes());
    w.bytes(&k16.to_le_bytes());
    w.bytes(&count16.to_le_bytes());
    w.f32(params.omega);
    let crc = crc32(payload);
    let mut w = Writer { buf: header, at: 0 };
    w.bytes(&MAGIC);
    w.bytes(&VERSION.to_le_bytes());
    w.bytes(&0u16.to_le_bytes());
    w.bytes(&payload_len.to_le_bytes());
    w.bytes(&crc.to_le_bytes());
    Ok(total)
}

/// A cursor over a buffer whose size was checked beforehand (writes past the end are dropped).
struct Writer<'b> {
    buf: &'b mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, data: &[u8]) {
        if let Some(dst) = self.buf.get_mut(self.at..self.at + data.len()) {
            dst.copy_from_slice(data);
        }
        self.at += data.len();
    }

    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use crate::Recognizer;
    use std::vec;
    use std::vec::Vec;

    use super::*;
    use crate::borders::contour::Point;

    /// Border of an axis-aligned `w`×`h` rectangle traced like Suzuki–Abe would (closed ring).
    fn rectangle(w: u16, h: u16) -> Vec<Point> {
        let mut b = Vec::new();
        (0..h).for_each(|y| b.push(Point { x: 0, y }));
        (0..w).for_each(|x| b.push(Point { x, y: h }));
        (1..=h).rev().for_each(|y| b.push(Point { x: w, y }));
        (1..=w).rev().for_each(|x| b.push(Point { x, y: 0 }));
        b
    }

    /// An L-shaped border (not symmetric).
    fn ell() -> Vec<Point> {
        let corners = [(0u16, 0u16), (0, 30), (20, 30), (20, 20), (10, 20), (10, 0)];
        let mut b = Vec::new();
        for (i, &(x0, y0)) in corners.iter().enumerate() {
            let (x1, y1) = corners[(i + 1) % corners.len()];
            let steps = x0.abs_diff(x1).max(y0.abs_diff(y1));
            for s in 0..steps {
                let t = |a: u16, b: u16| (a as i32 + (b as i32 - a as i32) * s as i32 / steps as i32) as u16;
                b.push(Point {
                    x: t(x0, x1),
                    y: t(y0, y1),
                });
            }
        }
        b
    }

    fn library() -> (Vec<u8>, Vec<Template<96>>) {
        let p = Params::DEFAULT;
        let ts = vec![
            Template::<96>::from_border(&rectangle(40, 16), core::iter::empty(), &p).unwrap(),
            Template::<96>::from_border(&ell(), core::iter::empty(), &p).unwrap(),
        ];
        let mut bytes = vec![0u8; encoded_len(2, p.m)];
        let len = write_library(&mut bytes, &p, [("bar", &ts[0]), ("ell_bracket", &ts[1])]).unwrap();
        assert_eq!(len, bytes.len());
        (bytes, ts)
    }

    /// Recomputes the stored CRC after a deliberate edit of the payload.
    fn reseal(bytes: &mut [u8]) {
        let crc = crc32(&bytes[HEADER_LEN..]);
        bytes[12..16].copy_from_slice(&crc.to_le_bytes());
    }

    #[test]
    fn crc32_check_values() {
        assert_eq!(crc32(b""), 0);
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b"The quick brown fox jumps over the lazy dog"), 0x414F_A339);
    }

    #[test]
    fn round_trip_is_exact() {
        let (bytes, ts) = library();
        assert_eq!(bytes.len(), 16 + 12 + 2 * (172 + 28 * 96));
        assert_eq!(&bytes[..4], b"VRLT");
        let lib = Library::parse(&bytes).unwrap();
        assert_eq!((lib.n(), lib.m(), lib.k(), lib.omega(), lib.len()), (64, 96, 4, 0.5, 2));
        assert_eq!(lib.name(0), Some("bar"));
        assert_eq!(lib.name(1), Some("ell_bracket"));
        assert_eq!(lib.name(2), None);
        assert_eq!(lib.template::<96>(0).unwrap(), ts[0]);
        assert_eq!(lib.template::<128>(1).unwrap().points(), ts[1].points());
        assert!(matches!(lib.template::<64>(0), Err(Error::Capacity { .. })));
        assert!(matches!(lib.template::<96>(2), Err(Error::Capacity { .. })));
    }

    #[test]
    fn load_library_into_a_recognizer() {
        let (bytes, ts) = library();
        let lib = Library::parse(&bytes).unwrap();
        let mut rec = Recognizer::<4, 96, 256, 4, 2112>::new();
        let mut p = Params::DEFAULT;
        p.n = 48;
        p.m = 72;
        p.k = 3;
        p.epsilon = 0.05;
        rec.set_params(p).unwrap();
        assert_eq!(rec.load_library(&lib).unwrap(), 2);
        assert_eq!(rec.templates(), &ts[..]);
        assert_eq!(
            (rec.params().n, rec.params().m, rec.params().k, rec.params().epsilon),
            (64, 96, 4, 0.05)
        );
        let mut small = Recognizer::<1, 96, 256, 4, 2112>::new();
        assert!(matches!(
            small.load_library(&lib),
            Err(Error::Capacity {
                what: "templates T",
                ..
            })
        ));
        let mut short = Recognizer::<4, 64, 256, 4, 2112>::new();
        assert!(matches!(short.load_library(&lib), Err(Error::Capacity { .. })));
    }

    #[test]
    fn bad_magic() {
        let (mut bytes, _) = library();
        bytes[0] = b'X';
        assert_eq!(Library::parse(&bytes).unwrap_err(), Error::BadMagic);
        assert_eq!(Library::parse(&[0u8; 64]).unwrap_err(), Error::BadMagic);
    }

    #[test]
    fn bad_version() {
        let (mut bytes, _) = library();
        for version in [0u16, 3, 0xFFFF] {
            bytes[4..6].copy_from_slice(&version.to_le_bytes());
            assert_eq!(
                Library::parse(&bytes).unwrap_err(),
                Error::UnsupportedVersion {
                    found: version,
                    supported: 2
                }
            );
        }
    }

    /// A washer-like square ring: its hole is kept and read back; a version 1 library (the
    /// same records without their hole blocks) is read too, its templates without holes.
    #[test]
    fn holes_round_trip_and_version_1_is_read() {
        let p = Params::DEFAULT;
        let hole: Vec<Point> = rectangle(10, 10)
            .iter()
            .map(|q| Point {
                x: q.x + 10,
                y: q.y + 10,
            })
            .collect();
        let ring = Template::<96>::from_border(&rectangle(30, 30), [&hole[..]].into_iter(), &p).unwrap();
        // The hole border runs through the ring's pixels around a 9×9 hole centred at (15, 15);
        // the ring's area centroid is (15, 15) too.
        assert_eq!(ring.holes().len(), 1);
        let h = ring.holes().as_slice()[0];
        assert_eq!(h.area, 81.0);
        assert!(h.centre[0].abs() < 1e-4 && h.centre[1].abs() < 1e-4);
        let mut bytes = vec![0u8; encoded_len(1, p.m)];
        write_library(&mut bytes, &p, [("ring", &ring)]).unwrap();
        let lib = Library::parse(&bytes).unwrap();
        assert_eq!(lib.template::<96>(0).unwrap(), ring);
        // Version 1: drop the hole block, fix the header's version, length and CRC.
        let v1_len = 60 + 28 * p.m;
        let mut v1 = bytes[..HEADER_LEN + PARAMS_LEN + v1_len].to_vec();
        v1[4..6].copy_from_slice(&1u16.to_le_bytes());
        v1[8..12].copy_from_slice(&((PARAMS_LEN + v1_len) as u32).to_le_bytes());
        reseal(&mut v1);
        let old = Library::parse(&v1).unwrap().template::<96>(0).unwrap();
        assert!(old.holes().is_empty());
        assert_eq!(old.points(), ring.points());
        // A hole count over 8 is corrupt.
        let count_at = HEADER_LEN + PARAMS_LEN + 60 + 28 * p.m;
        bytes[count_at..count_at + 4].copy_from_slice(&9u32.to_le_bytes());
        reseal(&mut bytes);
        assert!(matches!(Library::parse(&bytes), Err(Error::Corrupt { .. })));
    }

    #[test]
    fn truncated() {
        let (bytes, _) = library();
        let full = bytes.len();
        for cut in [0, 3, 15, 16, 28, full / 2, full - 1] {
            let err = Library::parse(&bytes[..cut]).unwrap_err();
            let needed = if cut < HEADER_LEN { HEADER_LEN } else { full };
            assert_eq!(err, Error::Truncated { needed, got: cut }, "cut at {cut}");
        }
    }

    #[test]
    fn bad_checksum() {
        let (bytes, _) = library();
        // Any single flipped bit in the payload, or in the stored CRC itself.
        for at in [16, 23, 30, 100, bytes.len() - 1, 12] {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            assert!(matches!(Library::parse(&b), Err(Error::Checksum { .. })), "byte {at}");
        }
        let mut b = bytes.clone();
        b[200] ^= 1;
        let Err(Error::Checksum { stored, computed }) = Library::parse(&b) else {
            panic!("no checksum error")
        };
        assert_eq!(stored, crc32(&bytes[HEADER_LEN..]));
        assert_eq!(computed, crc32(&b[HEADER_LEN..]));
    }

    #[test]
    fn inconsistent_counts_are_corrupt() {
        let (bytes, _) = library();
        let corrupt = |edit: &dyn Fn(&mut Vec<u8>)| {
            let mut b = bytes.clone();
            edit(&mut b);
            reseal(&mut b);
            Library::parse(&b).unwrap_err()
        };
        // Template count 3 but records for 2.
        assert!(matches!(
            corrupt(&|b| b[22..24].copy_from_slice(&3u16.to_le_bytes())),
            Error::Corrupt { .. }
        ));
        // m = 200 ≥ 2n.
        assert!(matches!(
            corrupt(&|b| b[18..20].copy_from_slice(&200u16.to_le_bytes())),
            Error::Corrupt { .. }
        ));
        // k = 40, 2k ≥ n.
        assert!(matches!(
            corrupt(&|b| b[20..22].copy_from_slice(&40u16.to_le_bytes())),
            Error::Corrupt { .. }
        ));
        // ω = 2.
        assert!(matches!(
            corrupt(&|b| b[24..28].copy_from_slice(&2.0f32.to_le_bytes())),
            Error::Corrupt { .. }
        ));
        // A NaN point.
        assert!(matches!(
            corrupt(&|b| b[28 + 60..28 + 64].copy_from_slice(&f32::NAN.to_le_bytes())),
            Error::Corrupt { .. }
        ));
        // Name length 40.
        assert!(matches!(corrupt(&|b| b[28] = 40), Error::Corrupt { .. }));
        // Name not UTF-8.
        assert!(matches!(corrupt(&|b| b[29] = 0xFF), Error::Corrupt { .. }));
        // The largest counts the fields can hold: no overflow, just an inconsistent size.
        assert!(matches!(
            corrupt(&|b| {
                for at in [16, 18, 22] {
                    b[at..at + 2].copy_from_slice(&u16::MAX.to_le_bytes());
                }
            }),
            Error::Corrupt { .. }
        ));
        // Trailing bytes after a consistent payload.
        let mut b = bytes.clone();
        b.extend_from_slice(&[0; 4]);
        assert!(matches!(Library::parse(&b), Err(Error::Corrupt { .. })));
        // Payload length that disagrees with the counts (a record dropped, the rest consistent).
        let mut b = bytes[..bytes.len() - record_len(96)].to_vec();
        let len = (b.len() - HEADER_LEN) as u32;
        b[8..12].copy_from_slice(&len.to_le_bytes());
        reseal(&mut b);
        assert!(matches!(Library::parse(&b), Err(Error::Corrupt { .. })));
    }

    #[test]
    fn writer_checks_its_inputs() {
        let p = Params::DEFAULT;
        let t = Template::<96>::from_border(&rectangle(20, 10), core::iter::empty(), &p).unwrap();
        let mut small = vec![0u8; encoded_len(1, p.m) - 1];
        assert!(matches!(
            write_library(&mut small, &p, [("a", &t)]),
            Err(Error::BufferTooSmall { .. })
        ));
        let mut buf = vec![0u8; encoded_len(1, p.m)];
        let long = "a_name_that_is_much_too_long_for_the_field";
        assert!(matches!(
            write_library(&mut buf, &p, [(long, &t)]),
            Err(Error::Capacity { .. })
        ));
        let mut q = p;
        q.n = 48;
        q.m = 72;
        q.k = 3;
        assert!(matches!(
            write_library(&mut buf, &q, [("a", &t)]),
            Err(Error::PointCounts { .. })
        ));
        let empty = write_library::<96>(&mut buf, &p, []).unwrap();
        assert_eq!(empty, 28);
        assert!(Library::parse(&buf[..empty]).unwrap().is_empty());
    }
}
