//! Frame sources of `vorl serve`: the set's frames replayed, or scenes drawn live by the
//! generator.

use std::path::{Path, PathBuf};

use image::GrayImage;

use crate::gen::{GenOptions, MemorySet, Variant};
use crate::io::{file_name, load_gray};

/// One frame from a source: its name and its pixels, or why it could not be had.
#[derive(Debug)]
pub struct Captured {
    /// The frame's name (file name in replay, `g000001.png` and on from the generator).
    pub name: String,
    /// The frame, 8-bit gray, or the one-line error naming the file.
    pub image: Result<GrayImage, String>,
    /// A note on the file (converted to 8-bit gray, …).
    pub note: Option<String>,
}

/// A stream of frames.
pub trait FrameSource: Send {
    /// The next frame.
    fn next_frame(&mut self) -> Captured;
    /// One line saying what the source is.
    fn describe(&self) -> String;
}

/// The set's frames in name order, from the first again after the last.
pub struct Replay {
    frames: Vec<PathBuf>,
    next: usize,
}

impl Replay {
    /// A replay of these frame files.
    ///
    /// # Errors
    /// No frames.
    pub fn new(frames: Vec<PathBuf>, set: &Path) -> Result<Self, String> {
        if frames.is_empty() {
            return Err(format!(
                "{}: no frames to replay in frames/ (--source gen draws scenes instead)",
                set.display()
            ));
        }
        Ok(Replay { frames, next: 0 })
    }
}

impl FrameSource for Replay {
    fn next_frame(&mut self) -> Captured {
        let path = &self.frames[self.next % self.frames.len()];
        self.next = (self.next + 1) % self.frames.len();
        let name = file_name(path);
        match load_gray(path) {
            Ok(l) => Captured {
                name,
                image: Ok(l.image),
                note: l.note.map(|n| format!("{}: {n}", path.display())),
            },
            Err(e) => Captured {
                name,
                image: Err(e.to_string()),
                note: None,
            },
        }
    }

    fn describe(&self) -> String {
        format!("replay of {} frame(s), looping", self.frames.len())
    }
}

/// Scenes drawn by the generator, one new scene per frame.
pub struct Generated {
    set: MemorySet,
    seed: u64,
    next: usize,
}

/// The generator's options for `vorl serve --source gen` (the default variant, 640×480).
pub fn gen_options(seed: u64) -> GenOptions {
    GenOptions {
        seed,
        frames: 1,
        variant: Variant::Default,
        ..GenOptions::default()
    }
}

impl Generated {
    /// The generator with this seed.
    ///
    /// # Errors
    /// The generator refuses the options.
    pub fn new(seed: u64) -> Result<Self, String> {
        let set = MemorySet::new(&gen_options(seed)).map_err(|e| e.to_string())?;
        Ok(Generated { set, seed, next: 0 })
    }
}

impl FrameSource for Generated {
    fn next_frame(&mut self) -> Captured {
        let (image, _truth) = self.set.frame(self.next);
        self.next += 1;
        Captured {
            name: format!("g{:06}.png", self.next),
            image: Ok(image),
            note: None,
        }
    }

    fn describe(&self) -> String {
        format!("scenes drawn live by the generator (seed {})", self.seed)
    }
}
