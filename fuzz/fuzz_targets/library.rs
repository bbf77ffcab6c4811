//! The template library parser on any bytes: `Library::parse`, then every query of a parsed
//! library, `Recognizer::load_library` into two recognizer configurations, and `write_library` back.
//!
//! Input: one mode byte, then the library's bytes. The mode's bits repair what random bytes
//! almost never get right, so that the checks after them are reached too: bit 0 sets the magic
//! and version, bit 1 the payload length (all bytes after the header), bit 2 the CRC-32.
//!
//! Checked: a library that parses is `len()` templates, each decodable, each named; loading it
//! into a recognizer that can hold it succeeds; and a library written from its templates parses
//! back to the same templates (`Template`'s `PartialEq`, as the module documents).

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::library::{crc32, encoded_len, write_library, Library};
use vorl_core::{Params, Recognizer, Template};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut bytes = rest.to_vec();
    if mode & 1 == 1 && bytes.len() >= 8 {
        bytes[..4].copy_from_slice(b"VRLT");
        bytes[4..6].copy_from_slice(&1u16.to_le_bytes());
    }
    if mode & 2 == 2 && bytes.len() >= 12 {
        let len = (bytes.len() - 16.min(bytes.len())) as u32;
        bytes[8..12].copy_from_slice(&len.to_le_bytes());
    }
    if mode & 4 == 4 && bytes.len() >= 16 {
        let len = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
        if let Some(payload) = bytes.get(16..16usize.saturating_add(len)) {
            let crc = crc32(payload);
            bytes[12..16].copy_from_slice(&crc.to_le_bytes());
        }
    }
    let _ = crc32(&bytes);
    let Ok(lib) = Library::parse(&bytes) else {
        return;
    };
    let _ = (lib.n(), lib.m(), lib.k(), lib.omega(), lib.is_empty(), lib.checksum());
    assert!(lib.name(lib.len()).is_none());
    assert!(lib.template::<128>(lib.len()).is_err());
    let mut templates: Vec<(String, Template<128>)> = Vec::new();
    for i in 0..lib.len() {
        let name = lib.name(i).expect("a parsed library names every template");
        let t = lib.template::<128>(i);
        if lib.m() <= 128 {
            templates.push((name.to_string(), t.expect("a parsed library decodes every template")));
        }
        let _ = lib.template::<16>(i);
    }
    let mut small = Box::new(Recognizer::<2, 16, 256, 8, 256>::new());
    let _ = small.load_library(&lib);
    let mut big = Box::new(Recognizer::<8, 128, 1024, 16, 8192>::new());
    let params = lib.params(Params::DEFAULT);
    let loaded = big.load_library(&lib);
    if lib.len() <= 8 && lib.m() <= 128 && params.validate().is_ok() && lib.n() * (lib.m() - lib.n() + 1) <= 8192 {
        assert_eq!(loaded, Ok(lib.len()), "a library that fits loads");
    }
    // Written back from its templates, it parses to the same templates.
    let mut out = vec![0u8; encoded_len(templates.len(), lib.m())];
    let items = templates.iter().map(|(n, t)| (n.as_str(), t));
    if write_library(&mut out, &params, items).is_ok() {
        let again = Library::parse(&out).expect("a written library parses");
        assert_eq!(again.len(), templates.len());
        for (i, (name, t)) in templates.iter().enumerate() {
            assert_eq!(again.name(i), Some(name.as_str()));
            assert_eq!(again.template::<128>(i).as_ref(), Ok(t), "template {i} read back");
        }
    }
    // Too small a buffer is an error, not a panic.
    let mut short = vec![0u8; out.len().saturating_sub(1)];
    let _ = write_library(&mut short, &params, templates.iter().map(|(n, t)| (n.as_str(), t)));
});
