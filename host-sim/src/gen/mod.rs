//! Deterministic synthetic fixture sets (DESIGN.md, "Contracts"): the empty platform with smooth
//! uneven lighting, industrial parts at random poses with partial-volume edges, optical blur and
//! sensor noise, the template silhouettes, and the exact truth.
//!
//! # What a set holds
//!
//! ```text
//! background.png              the empty platform (lighting + blur + fresh sensor noise)
//! backgrounds/bg_00..07.png   8 more captures of it (same lighting, fresh noise)
//! templates/<class>.png       silhouette at angle 0, pixel-centre rule, 255 on 0, ≥ 10 px margin
//! frames/f000.png …           2–5 non-overlapping parts on the platform per frame
//! truth.json                  {"frames": {"f000.png": [{"class", "x", "y", "angle_deg", "symmetry",
//!                             "scale", "contrast", "texture", "shape", …}]}}
//! parts.json                  the catalogue: class, symmetry, area, template file and where the
//!                             centroid lies in it, px per mm
//! variant.json                the real-camera variants only: the variant and its set-wide
//!                             parameters (lens, camera height, texture, vignette, …)
//! vorl.toml                   `rods` only: the set's own parameters (the scale range its parts need)
//! teach.json                  `frontlit` only: for each class, the first frame where a part of it
//!                             lies whole, and its truth centroid, or where that lies off the part
//!                             (an L bracket's) the nearest point 3 px inside it (DESIGN.md's
//!                             `teach.json`, the point `vorl teach --at` takes)
//! ```
//!
//! Stereo sets write `frames/left_f000.png` and `frames/right_f000.png`, `background_left.png`
//! (the same image as `background.png`), `background_right.png`, `backgrounds_right/`, and
//! `camera.json`; truth is keyed by `f000.png`, positions in the left image, plus `z_mm` and
//! `disparity_px`.
//!
//! Without a background ([`GenOptions::background`] `Some(false)`, `vorl gen --no-background`;
//! the default of `backlit` and `rods`) no `background*.png` and no `backgrounds*/` are written: the contract
//! allows that, the platform is then estimated from the frames.
//!
//! # Variants
//!
//! The ideal camera: `default`, `noisy`, `small`, `border`, `stereo` (see [`Variant`]). The
//! real-camera variants each add one failure mode a real smart camera shows; all of them draw
//! σ = 2 noise, lighting drift up to ±1.5 levels, contrast 40–90 levels, parts at 1 px per mm:
//!
//! | variant    | what it draws | truth |
//! |------------|---------------|-------|
//! | `sharp`    | its own catalogue of sharp-cornered parts ([`sharp_catalogue`]: a 12-tooth gear with rectangular teeth and a 10-tooth one of the same radii, a snail cam with a step, a square-cornered L bracket, …) under the same 0.7 px optical blur; templates are the crisp silhouettes | as `default` |
//! | `lens`     | a barrel-distorted lens: `p_d = c + (p − c)(1 + k1·|p − c|²/r²)`, `r` half the frame diagonal, `c` within ±1.5 % of the centre, `k1 < 0` moving the farthest frame corner 3–6 px inward; every ring cut into ≤ 0.5 px pieces and distorted, the platform seen through the lens too; templates undistorted | `x`, `y` = the distorted image of the part's centroid; `angle_deg` = the drawn angle plus `lens_rotation_deg`, the rotation of the least-squares similarity from the undistorted border onto the distorted one (the Jacobian of a radial distortion is symmetric, so its own rotation is 0, but its anisotropic stretch turns an elongated part by up to a few tenths of a degree near the corners); adds `angle_drawn_deg`, `lens_rotation_deg`, `lens_scale`, `x_undistorted`, `y_undistorted` and `area_x`, `area_y` (the area centroid of the distorted silhouette: what a centroid measures in the image, up to about 0.2 px from `x`, `y` for a large part near the frame corners, since the distortion's scale varies over the part) |
//! | `thick`    | a close pinhole camera (450–600 mm above the platform, principal point at the frame centre) over parts 4–20 mm thick: the bottom face at the platform's scale, the top face magnified by `H/(H − t)` about the principal point, the walls between them (the exact sweep, at 75–100 % of the contrast); parts away from the centre look stretched outward | the top face's pose: `x`, `y` its centroid, `scale` its size over the template's; adds `thickness_mm`, `top_scale` (`H/(H − t)`), `bottom_x`, `bottom_y` (the bottom face's centroid), `wall_contrast` |
//! | `exposure` | every frame at its own exposure: gain 0.6–1.4 and offset ±10 levels over the whole image (platform and parts; bright parts may clip at 255); `background*.png` at gain 1. Frames come in pairs, one scene at two exposures (f000/f001, f002/f003, …, gains at least 0.2 apart) with fresh noise | adds `gain`, `offset` and `scene` (the pair's index) |
//! | `paper`    | a textured paper or belt platform: speckle correlated over about 2 px plus fibres, standard deviation 3–5 levels, part of the platform (in `background*.png` and every frame alike, hidden under the parts), plus the usual sensor noise | as `default` |
//! | `printed`  | 70 % of the parts carry print: rows of dark text-like glyph blobs and a logo ring (on a dark part darker still, on a light part darker than the platform), and on dark parts light patches within 8 levels of the platform that a mask may cut as holes; templates plain | the part's own centroid (print ignored); `texture` `"print"`, adds `print_marks` and `print_patches` |
//! | `backlit`  | dark opaque parts (gray 8–35) on a bright backlight with cos⁴ vignetting: 246–252 at the optical centre, 145–155 at the farthest corner; no `background.png` unless asked for | as `default`; `contrast` = level − backlight at the centroid, adds `level` |
//! | `frontlit` | metal parts on a grey textured mat (level 105–125, texture σ 3–5) under diffuse light from one direction per set (`light_from_deg`, 110–160°: about the upper left): each part 55–105 levels above the lit mat, shaded ±5–15 levels towards the light, with one darker facet over 5–15 % of its area (its edge away from the light at −15…+5 levels from the mat, or a band across it at 40–70 % of its contrast) and 1–2 specular highlights; each part's silhouette moved 4–10 px away from the light, blurred by σ 2–4 px, darkens the mat by 20–50 levels under it (the part hides its own shadow); `background.png` is the empty mat; a `teach.json` | the part's own silhouette (never the shadow); `texture` `"metal"`, adds `light_from_deg`, `shadow_dx`, `shadow_dy`, `shadow_sigma`, `shadow_depth`, `facet` (`"edge"` or `"band"`), `facet_share`, `facet_level`, `highlights` |
//! | `frontlit-mixed` | as `frontlit`, with the parts of each class dark with chance ½ (`dark_classes` in `variant.json`): 45–95 levels below the lit mat, a band facet at 40–70 % of that contrast, highlights as the others; their shadows join them | as `frontlit`, adding `"dark": true` to each dark part |
//! | `large`    | its own catalogue ([`large_catalogue`]): one large part per frame, a guitar pick or a standard part scaled to cover 26–45 % of the frame ([`LARGE_SHARES`]; templates at the same scale), opaque, dark (20–120) or bright (238–250), the pick and the gear taught, the others (a hex nut, a washer, a square flange, a cam, a blob) not, in 60 % of the frames a taught one; and up to two small distractors (a star, a crescent) where they fit; on white paper (200–225, smooth lighting ±6–14, texture σ 1.5–3) printed with lines of dark text-like glyphs (80–150 levels below the paper) on ruled lines (30–70 below) in one or two columns, the page turned ±8°; the print is part of the platform (in `background*.png` too) and hidden under the parts | as `default`, adds `level`; `contrast` = level − the paper's level at the centroid |
//! | `rods`     | its own catalogue ([`rods_catalogue`]) on the `backlit` backlight: connecting rods `rod_a` (one eye, in the big end) and `rod_b` (the same outline, a larger eye in the big end and a smaller one in the small end, both with thin rims like the real rods': 8 and 5.5 mm), each rod made with its own proportions (shaft length ×0.85–1.15, each head's radius ×0.92–1.08, each eye's ×0.9–1.1) and drawn at 0.9–1.3× the template's size; washers and screws (shank ×0.85–1.15) as distractors; templates the nominal rods; no `background.png` unless asked for; a `vorl.toml` with `scale_min = 0.8` (0.9× drawn, a shaft 15 % short), `scale_max = 1.4` | as `backlit`: the drawn part's centroid and rotation (the template's reference pose: axis along x, big end at −x); `scale` the drawn size over the template's, adds `stretch` and the rods' `head_big_scale`, `head_small_scale`, `eye_big_scale`, `eye_small_scale` (`rod_b`) |
//!
//! # Truth
//!
//! Parts are polygons in their own millimetre frame (see [`catalogue`]) with the area centroid
//! of the silhouette (holes removed) at the origin; a part is drawn by the similarity
//! `p = (x, y) + k·(dx·cosθ + dy·sinθ, −dx·sinθ + dy·cosθ)` (θ counter-clockwise on screen, y down,
//! k = px per mm × scale), so the truth position is exactly the drawn centroid and `angle_deg` is
//! exactly θ. Each pixel's coverage is exact along x and sampled on 16 lines along y, which puts
//! the coverage centroid within 0.003 px of the truth for every catalogue part (tested at 0.02).
//! `lens` and `thick` follow the table above.
//!
//! # Determinism
//!
//! Every random choice comes from a stream keyed by (seed, purpose, index) — one per frame for the
//! layout, one per image for the noise — so frames may be made in parallel and the same options
//! give byte-identical files. Nothing depends on time or on hash-map order. The real-camera
//! variants draw their own choices from streams of their own, so the ideal-camera variants give
//! the same files as before they existed.

mod effects;
mod frontlit;
mod large;
mod output;
mod print;
mod raster;
mod render;
mod rng;
mod scene;
mod shapes;
mod touching;
#[cfg(test)]
mod variant_tests;

pub use shapes::{
    catalogue, flipped_catalogue, large_catalogue, lookalike_catalogue, rods_catalogue, sharp_catalogue, PartSpec,
    LARGE_REFERENCE_PX, LARGE_SHARES,
};

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;

use rayon::prelude::*;
use serde_json::json;

use crate::truth::{FramesJson, PartJson};
use effects::{paper_texture, Backlight, CloseCamera, Lens, PAPER_STD};
use frontlit::FrontLight;
use raster::{bounds, coverage_union};
use render::{
    add_drift, blur, capture, draw_part, draw_part_through, silhouette, template, Appearance, Lighting, Texture,
    BLUR_SIGMA, SUBROWS,
};
use rng::{purpose, Rng};
use scene::{plan, Body, CloseFit, Placed, SceneConfig, StereoRig};

/// The `touching` variant's `vorl.toml`: the partial search on (the default since 2026-12-06;
/// kept, so the set says what it needs).
pub const TOUCHING_CONFIG: &str = "# Parameters for this set (keys of `vorl config --defaults`).\n\
# Parts touch and lie over one another: search the blobs for the parts along them.\n\
touching_parts = true\n";

/// The `rods-touching` set's `vorl.toml`: [`RODS_CONFIG`]'s scale range and the partial search.
pub const RODS_TOUCHING_CONFIG: &str = concat!(
    rods_config!(),
    "# Rods lie against and over one another: search the blobs for the parts along them.\n\
    touching_parts = true\n"
);

/// Share of the chiral template parts that the `flipped` variant lays upside down.
pub const FLIPPED_SHARE: f64 = 0.5;

/// Nominal scale of parts and templates, px per mm (all variants but `small`).
pub const PX_PER_MM: f64 = 1.0;
/// Nominal scale of the `small` variant, px per mm (parts 35–55 px across).
pub const SMALL_PX_PER_MM: f64 = 0.4;
/// Stereo focal length, px.
pub const STEREO_F_PX: f64 = 800.0;
/// Stereo baseline (right camera at +baseline along x), mm.
pub const STEREO_BASELINE_MM: f64 = 60.0;
/// Depth of the platform plane in stereo sets, mm (f/Z0 = 1 px per mm, the templates' scale).
pub const STEREO_PLATFORM_Z_MM: f64 = 800.0;
/// Extra captures of the empty platform in `backgrounds/`.
pub const BACKGROUND_CAPTURES: usize = 8;
/// Height of the close camera above the platform in `thick` sets, mm (drawn per set).
pub const THICK_CAMERA_HEIGHT_MM: (f64, f64) = (450.0, 600.0);
/// Thickness of the parts in `thick` sets, mm.
pub const THICKNESS_MM: (f64, f64) = (4.0, 20.0);
/// Exposure gain of a frame in `exposure` sets.
pub const EXPOSURE_GAIN: (f64, f64) = (0.6, 1.4);
/// Exposure offset of a frame in `exposure` sets, levels.
pub const EXPOSURE_OFFSET: (f64, f64) = (-10.0, 10.0);
/// Least difference of the gains of the two frames of one scene in `exposure` sets.
pub const EXPOSURE_GAIN_STEP: f64 = 0.2;
/// Gray level of the opaque parts in `backlit` sets.
pub const BACKLIT_PART_LEVEL: (f64, f64) = (8.0, 35.0);
/// Scale of a part over its template in `rods` sets (the camera height changes).
pub const ROD_SCALE: (f64, f64) = (0.9, 1.3);
/// Length of a rod's shaft (a screw's shank) over the nominal one in `rods` sets.
pub const ROD_STRETCH: (f64, f64) = (0.85, 1.15);
/// Radius of each head of a rod over the nominal one in `rods` sets.
pub const ROD_HEAD: (f64, f64) = (0.92, 1.08);
/// Radius of each eye of a rod over the nominal one in `rods` sets.
pub const ROD_EYE: (f64, f64) = (0.9, 1.1);

/// The text of [`RODS_CONFIG`], a literal so that [`RODS_TOUCHING_CONFIG`] can extend it.
macro_rules! rods_config {
    () => {
        "# Parameters for this set (keys of `vorl config --defaults`).\n\
        # Rods differ part to part and the camera height changes: parts are drawn at 0.9-1.3x their\n\
        # template, and a shaft 15 % shorter makes the outline's best fit 0.93x smaller again.\n\
        scale_min = 0.8\n\
        scale_max = 1.4\n"
    };
}
use rods_config;

/// The `vorl.toml` of a `rods` set: the scale range its parts need (keys of
/// `vorl config --defaults`).
pub const RODS_CONFIG: &str = rods_config!();

/// The kind of set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// σ = 2 noise, contrast 40–90 levels, parts 88–138 px across.
    Default,
    /// σ = 5 noise, lighting drift up to ±8 levels per frame, contrast 30–70 levels.
    Noisy,
    /// Parts and templates at 0.4 px per mm: 35–55 px across.
    Small,
    /// About 40 % of the parts cut by the frame border (`"partial": true`).
    Border,
    /// A rectified stereo pair per frame; parts 5–60 mm above the platform.
    Stereo,
    /// Sharp-cornered parts ([`sharp_catalogue`]) under 0.7 px optical blur; crisp templates.
    Sharp,
    /// A barrel-distorted lens (frame corners 3–6 px inward); truth at the distorted centroid.
    Lens,
    /// A close camera seeing thick parts' walls; truth is the top face's pose.
    Thick,
    /// Gain 0.6–1.4 and offset ±10 per frame; frames in pairs of one scene at two exposures.
    Exposure,
    /// A textured paper or belt platform (speckle and fibres, in the background too).
    Paper,
    /// Dark print, a logo ring and light hole-like patches on the parts' faces.
    Printed,
    /// Dark parts on a vignetted backlight (250 at the centre, about 150 in the corners); no
    /// background by default.
    Backlit,
    /// Backlit connecting rods of two types that differ in their eyes (holes), each rod with
    /// proportions of its own, at 0.9–1.3× the template's size; washers and screws as
    /// distractors. No background by default; a `vorl.toml` with the scale range.
    Rods,
    /// As `default`, with a J hook, a long L bracket and a pin whose ends only a hole too small
    /// for the tracing tells apart added, and about half of the chiral template parts (those
    /// whose mirror image matches no turn of them: `l_bracket`, `shaft_key`, `wrench`, `hook`,
    /// `l_long`) lying upside down; truth adds `"flipped": true` and `"chiral"`.
    Flipped,
    /// As `default`, with about 60 % of the parts moved against another part, merely touching
    /// it or lying over it by up to 12 % of the smaller one's area, and about half of the
    /// chiral template parts (`l_bracket`, `shaft_key`, `wrench`) lying upside down; truth marks
    /// both `"touching": true`, and the lower one's `visible_fraction`, and adds `"flipped"`
    /// and `"chiral"` as `flipped` does.
    Touching,
    /// As `rods`, with the parts moved against and over one another as in `touching` (two real
    /// rods lying against each other, each off its template's outline, as in the real photos'
    /// `TESI50`); a `vorl.toml` with the scale range and `touching_parts = true`.
    RodsTouching,
    /// Metal parts on a grey textured mat under diffuse light from one side (about the upper
    /// left): parts brighter than the mat, shaded, with a dark facet and highlights, each
    /// throwing a soft shadow away from the light; writes a `teach.json`.
    Frontlit,
    /// As `frontlit`, with the parts of about half of the classes dark (blackened steel, dark
    /// plastic: 45–95 levels below the mat, a band facet): a set of both kinds, whose teach
    /// leaves the polarity "either"; truth adds `"dark": true` to each dark part.
    FrontlitMixed,
    /// As `default`, with untaught parts that look like templates but lack their bore or holes
    /// ([`lookalike_catalogue`]: a solid cam, hex nut, 12-tooth gear, disc, oval flange, L and U
    /// bracket, a hex nut and a washer with a bore half as wide) among
    /// the distractors: their outline verifies against the template, their holes do not.
    Lookalike,
    /// One large part (a quarter to a half of the frame, dark or bright; [`large_catalogue`]: a
    /// guitar pick and standard parts scaled up; the pick and a gear taught) and up to two small ones on white paper printed
    /// with text and ruled lines (in the background too, hidden under the parts).
    Large,
}

impl Variant {
    /// All variants.
    pub const ALL: [Variant; 20] = [
        Variant::Default,
        Variant::Noisy,
        Variant::Small,
        Variant::Border,
        Variant::Stereo,
        Variant::Sharp,
        Variant::Lens,
        Variant::Thick,
        Variant::Exposure,
        Variant::Paper,
        Variant::Printed,
        Variant::Backlit,
        Variant::Rods,
        Variant::Flipped,
        Variant::Touching,
        Variant::RodsTouching,
        Variant::Frontlit,
        Variant::FrontlitMixed,
        Variant::Lookalike,
        Variant::Large,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Default => "default",
            Variant::Noisy => "noisy",
            Variant::Small => "small",
            Variant::Border => "border",
            Variant::Stereo => "stereo",
            Variant::Sharp => "sharp",
            Variant::Lens => "lens",
            Variant::Thick => "thick",
            Variant::Exposure => "exposure",
            Variant::Paper => "paper",
            Variant::Printed => "printed",
            Variant::Backlit => "backlit",
            Variant::Rods => "rods",
            Variant::Flipped => "flipped",
            Variant::Touching => "touching",
            Variant::RodsTouching => "rods-touching",
            Variant::Frontlit => "frontlit",
            Variant::FrontlitMixed => "frontlit-mixed",
            Variant::Lookalike => "lookalike",
            Variant::Large => "large",
        }
    }

    /// The parts this variant draws: [`sharp_catalogue`] for `sharp`, [`rods_catalogue`] for
    /// `rods` and `rods-touching`, [`catalogue`] otherwise.
    pub fn catalogue(self) -> Vec<PartSpec> {
        match self {
            Variant::Sharp => sharp_catalogue(),
            Variant::Rods | Variant::RodsTouching => rods_catalogue(),
            Variant::Lookalike => lookalike_catalogue(),
            Variant::Flipped => flipped_catalogue(),
            Variant::Large => large_catalogue(),
            _ => catalogue(),
        }
    }

    /// Whether the variant draws backlit rods that differ part to part (`rods`,
    /// `rods-touching`).
    pub fn is_rods(self) -> bool {
        matches!(self, Variant::Rods | Variant::RodsTouching)
    }

    /// For each part of the [`Self::catalogue`], whether it is a chiral template (its mirror
    /// image matches no turn of it): what `flipped` and `touching` lay upside down.
    pub fn chiral_templates(self) -> Vec<bool> {
        self.catalogue()
            .iter()
            .map(|p| p.is_template && p.is_chiral())
            .collect()
    }

    /// Whether the variant moves parts against and over one another (`touching`,
    /// `rods-touching`).
    pub fn is_touching(self) -> bool {
        matches!(self, Variant::Touching | Variant::RodsTouching)
    }

    /// The name of the catalogue [`Variant::catalogue`] gives: `"sharp"`, `"rods"` or
    /// `"standard"` (variants of one name draw the same parts).
    pub fn catalogue_name(self) -> &'static str {
        match self {
            Variant::Sharp => "sharp",
            Variant::Rods | Variant::RodsTouching => "rods",
            Variant::Lookalike => "lookalike",
            Variant::Flipped => "flipped",
            Variant::Large => "large",
            _ => "standard",
        }
    }

    /// Whether the set gets `background.png` and `backgrounds/` unless told otherwise (all but
    /// `backlit`, `rods` and `rods-touching`).
    pub fn writes_background(self) -> bool {
        !(self == Variant::Backlit || self.is_rods())
    }

    /// The set's own `vorl.toml`, for the variants whose parts need other parameters than the
    /// defaults (`rods`: [`RODS_CONFIG`]; `touching`: [`TOUCHING_CONFIG`]; `rods-touching`:
    /// [`RODS_TOUCHING_CONFIG`]).
    pub fn set_config(self) -> Option<&'static str> {
        match self {
            Variant::Rods => Some(RODS_CONFIG),
            Variant::Touching => Some(TOUCHING_CONFIG),
            Variant::RodsTouching => Some(RODS_TOUCHING_CONFIG),
            _ => None,
        }
    }

    /// Whether the set gets a `teach.json` (`frontlit`, `frontlit-mixed`): for each class, the first frame where a
    /// part of it lies whole and its truth centroid (or, where that lies off the part, the
    /// nearest point 3 px inside it).
    pub fn writes_teach(self) -> bool {
        matches!(self, Variant::Frontlit | Variant::FrontlitMixed)
    }

    /// One of the variants that model a real camera's failure modes (they write `variant.json`).
    pub fn is_real_camera(self) -> bool {
        !matches!(
            self,
            Variant::Default
                | Variant::Noisy
                | Variant::Small
                | Variant::Border
                | Variant::Stereo
                | Variant::Flipped
                | Variant::Touching
                | Variant::Lookalike
        )
    }
}

impl fmt::Display for Variant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Variant {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Variant::ALL
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                let names: Vec<&str> = Variant::ALL.iter().map(|v| v.name()).collect();
                format!("unknown variant '{s}' (valid: {})", names.join(", "))
            })
    }
}

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct GenOptions {
    /// Seed of every random choice.
    pub seed: u64,
    /// Number of frames (stereo: pairs).
    pub frames: usize,
    /// Kind of set.
    pub variant: Variant,
    /// Frame width, px (32–16384).
    pub width: u32,
    /// Frame height, px (32–16384).
    pub height: u32,
    /// Whether to write `background*.png` and `backgrounds*/`; `None`: the variant's default
    /// ([`Variant::writes_background`]). Frames and truth do not depend on it.
    pub background: Option<bool>,
}

impl Default for GenOptions {
    fn default() -> Self {
        GenOptions {
            seed: 1,
            frames: 60,
            variant: Variant::Default,
            width: 640,
            height: 480,
            background: None,
        }
    }
}

impl GenOptions {
    /// Whether the set gets its background captures.
    pub fn writes_background(&self) -> bool {
        self.background.unwrap_or(self.variant.writes_background())
    }
}

/// What was generated.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GenSummary {
    /// Frames written (stereo: pairs).
    pub frames: usize,
    /// Parts over all frames.
    pub parts: usize,
    /// Parts whose class is a template.
    pub known_parts: usize,
    /// Distractors (class `null`).
    pub unknown_parts: usize,
    /// Parts cut by the frame border.
    pub partial_parts: usize,
    /// Template classes, in catalogue order.
    pub classes: Vec<String>,
}

/// Why a set could not be written.
#[derive(Debug)]
pub enum GenError {
    /// A folder or file could not be created or written.
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// An image could not be encoded or written.
    Image {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: image::ImageError,
    },
    /// A JSON file could not be encoded.
    Json {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
    },
    /// The options are out of range.
    Options(String),
}

impl fmt::Display for GenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GenError::Io { path, source } => write!(f, "{}: {}", path.display(), source),
            GenError::Image { path, source } => {
                write!(f, "{}: cannot write image ({})", path.display(), source)
            }
            GenError::Json { path, source } => {
                write!(f, "{}: cannot encode JSON ({})", path.display(), source)
            }
            GenError::Options(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for GenError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            GenError::Io { source, .. } => Some(source),
            GenError::Image { source, .. } => Some(source),
            GenError::Json { source, .. } => Some(source),
            GenError::Options(_) => None,
        }
    }
}

/// What a real-camera variant puts between the scene and the sensor.
#[derive(Clone, Debug)]
enum Effect {
    /// The ideal camera (also `sharp`, whose change is its catalogue).
    Ideal,
    /// `lens`: the frame is seen through this lens.
    Lens(Lens),
    /// `thick`: a close camera over thick parts.
    Thick(CloseCamera),
    /// `exposure`: a gain and offset per frame.
    Exposure,
    /// `paper`: this texture (levels, row-major) is part of the platform.
    Paper { texture: Vec<f64>, std: f64 },
    /// `printed`: print on the parts.
    Printed,
    /// `backlit`: the platform is this backlight.
    Backlit(Backlight),
    /// `flipped`: which parts of the catalogue are chiral (by index); about half of those lie
    /// upside down.
    Flipped(Vec<bool>),
    /// `touching`: parts moved against and over one another; which parts of the catalogue are
    /// chiral (by index): about half of those lie upside down.
    Touching(Vec<bool>),
    /// `frontlit`: this light and mat (its texture part of the platform).
    Frontlit(FrontLight),
    /// `large`: this printed paper is the platform.
    Large(large::Paper),
}

/// Everything a frame needs that is fixed for the set.
struct SetPlan {
    seed: u64,
    w: usize,
    h: usize,
    variant: Variant,
    cat: Vec<PartSpec>,
    scene: SceneConfig,
    noise_sigma: f64,
    drift_max: f64,
    /// The empty platform of the (left) camera, before blur.
    light: Vec<f64>,
    /// Lighting of the right camera (stereo), before blur.
    light_right: Option<Vec<f64>>,
    effect: Effect,
    /// Parts are moved against and over one another ([`touching::bring_together`]).
    touching: bool,
}

impl SetPlan {
    fn new(opts: &GenOptions) -> Self {
        let (w, h) = (opts.width as usize, opts.height as usize);
        let mut rng = Rng::stream(opts.seed, purpose::SET, 0);
        let base = rng.range(120.0, 140.0);
        let amplitude = rng.range(10.0, 15.0);
        let lighting = Lighting::random(&mut rng, w, h, base, amplitude);
        let v = opts.variant;
        let stereo = (v == Variant::Stereo).then_some(StereoRig {
            f_px: STEREO_F_PX,
            baseline_mm: STEREO_BASELINE_MM,
            platform_z_mm: STEREO_PLATFORM_Z_MM,
        });
        let px_per_mm = match v {
            Variant::Small => SMALL_PX_PER_MM,
            Variant::Stereo => STEREO_F_PX / STEREO_PLATFORM_Z_MM,
            // The large parts' shares hold for any frame size.
            Variant::Large => (w as f64 / LARGE_REFERENCE_PX.0).min(h as f64 / LARGE_REFERENCE_PX.1),
            _ => PX_PER_MM,
        };
        let (contrast, min_contrast) = if v == Variant::Noisy {
            ((30.0, 70.0), 22.0)
        } else {
            ((40.0, 90.0), 30.0)
        };
        // The right camera sees the platform point that the left one sees at x + f·B/Z0.
        let light_right = stereo.map(|s| lighting.field(w, h, s.f_px * s.baseline_mm / s.platform_z_mm));
        // The real-camera variants draw from a stream of their own.
        let mut fx = Rng::stream(opts.seed, purpose::EFFECT_SET, 0);
        let effect = match v {
            Variant::Lens => Effect::Lens(Lens::random(&mut fx, w, h)),
            Variant::Thick => Effect::Thick(CloseCamera {
                centre: [(w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0],
                height_mm: fx.range(THICK_CAMERA_HEIGHT_MM.0, THICK_CAMERA_HEIGHT_MM.1),
            }),
            Variant::Paper => {
                let std = fx.range(PAPER_STD.0, PAPER_STD.1);
                Effect::Paper {
                    texture: paper_texture(&mut fx, w, h, std),
                    std,
                }
            }
            _ if v == Variant::Backlit || v.is_rods() => Effect::Backlit(Backlight::random(&mut fx, w, h)),
            Variant::Exposure => Effect::Exposure,
            Variant::Printed => Effect::Printed,
            Variant::Flipped => Effect::Flipped(v.chiral_templates()),
            Variant::Touching => Effect::Touching(v.chiral_templates()),
            Variant::Frontlit => Effect::Frontlit(FrontLight::random(&mut fx, w, h)),
            Variant::FrontlitMixed => {
                let light = FrontLight::random(&mut fx, w, h);
                let dark = v
                    .catalogue()
                    .iter()
                    .filter(|_| fx.chance(frontlit::MIXED_DARK_SHARE))
                    .map(|c| c.name)
                    .collect();
                Effect::Frontlit(FrontLight { dark, ..light })
            }
            Variant::Large => Effect::Large(large::Paper::random(&mut fx, w, h, px_per_mm)),
            _ => Effect::Ideal,
        };
        let light = match &effect {
            Effect::Lens(lens) => (0..h)
                .flat_map(|j| (0..w).map(move |i| (i, j)))
                .map(|(i, j)| {
                    let p = lens.undistort([i as f64, j as f64]);
                    lighting.at(p[0], p[1])
                })
                .collect(),
            Effect::Paper { texture, .. } => lighting
                .field(w, h, 0.0)
                .iter()
                .zip(texture)
                .map(|(l, t)| l + t)
                .collect(),
            Effect::Backlit(b) => b.field(w, h),
            Effect::Frontlit(f) => f.mat(),
            Effect::Large(p) => p.field().to_vec(),
            _ => lighting.field(w, h, 0.0),
        };
        let close = match &effect {
            Effect::Thick(camera) => Some(CloseFit {
                camera: *camera,
                s_max: camera.scale(THICKNESS_MM.1),
            }),
            _ => None,
        };
        SetPlan {
            seed: opts.seed,
            w,
            h,
            variant: v,
            cat: v.catalogue(),
            scene: SceneConfig {
                w,
                h,
                px_per_mm,
                contrast,
                min_contrast,
                border: v == Variant::Border,
                stereo,
                close,
                scale: if v.is_rods() { ROD_SCALE } else { (0.97, 1.03) },
                vary: v.is_rods(),
            },
            noise_sigma: if v == Variant::Noisy { 5.0 } else { 2.0 },
            drift_max: if v == Variant::Noisy { 8.0 } else { 1.5 },
            light,
            light_right,
            effect,
            touching: v.is_touching(),
        }
    }

    /// The set-wide parameters of a real-camera variant, for `variant.json`.
    fn describe(&self, background: bool) -> serde_json::Value {
        let mut v = json!({
            "variant": self.variant.name(),
            "background": background,
            "blur_sigma_px": BLUR_SIGMA,
            "noise_sigma": self.noise_sigma,
        });
        let params = match &self.effect {
            Effect::Lens(l) => json!({
                "model": "p_d = c + (p - c) * (1 + k1 * |p - c|^2 / r_norm^2), p undistorted, c = (cx, cy)",
                "cx": l.centre[0],
                "cy": l.centre[1],
                "k1": l.k1,
                "r_norm_px": l.r_norm,
                "corner_shift_px": l.corner_shift(self.w, self.h),
            }),
            Effect::Thick(c) => json!({
                "model": "pinhole looking down; a plane t mm above the platform is imaged at H / (H - t) times the platform's scale about (cx, cy)",
                "cx": c.centre[0],
                "cy": c.centre[1],
                "camera_height_mm": c.height_mm,
                "f_px": c.height_mm * self.scene.px_per_mm,
                "thickness_mm": [THICKNESS_MM.0, THICKNESS_MM.1],
            }),
            Effect::Paper { std, .. } => json!({ "texture_std": std }),
            Effect::Backlit(b) => json!({
                "model": "level / (1 + r^2 / f_px^2)^2, r from (cx, cy)",
                "cx": b.centre[0],
                "cy": b.centre[1],
                "level": b.level,
                "f_px": b.f_px,
                "corner_level": b.corner_level(self.w, self.h),
                "part_level": [BACKLIT_PART_LEVEL.0, BACKLIT_PART_LEVEL.1],
            }),
            Effect::Exposure => json!({
                "gain": [EXPOSURE_GAIN.0, EXPOSURE_GAIN.1],
                "offset": [EXPOSURE_OFFSET.0, EXPOSURE_OFFSET.1],
                "gain_step": EXPOSURE_GAIN_STEP,
                "pairs": "frames 2k and 2k+1 show scene k",
            }),
            Effect::Printed => json!({ "printed_share": print::PRINTED_SHARE }),
            Effect::Flipped(_) => json!({ "flipped_share": FLIPPED_SHARE }),
            Effect::Touching(_) => json!({
                "touching_share": touching::TOUCHING_SHARE,
                "overlap_max": touching::OVERLAP_MAX,
                "just_touching": touching::JUST_TOUCHING,
                "flipped_share": FLIPPED_SHARE,
            }),
            Effect::Frontlit(f) => json!({
                "model": "mat = smooth lighting + texture; part = lit mat + contrast + shading * (q . toward) / radius + highlights, or lit mat + facet_level on its facet; shadow = silhouette moved by offset, blurred by sigma, times depth, under the parts",
                "light_from_deg": f.from_deg,
                "light_toward": f.toward(),
                "mat_level": f.mat_level,
                "mat_lighting": f.mat_lighting,
                "texture_std": f.texture_std,
                "contrast": [frontlit::METAL_CONTRAST.0, frontlit::METAL_CONTRAST.1],
                "dark_classes": f.dark,
                "dark_contrast": [-frontlit::DARK_CONTRAST.1, -frontlit::DARK_CONTRAST.0],
                "shading": [frontlit::METAL_SHADING.0, frontlit::METAL_SHADING.1],
                "facet_share": [frontlit::FACET_SHARE.0, frontlit::FACET_SHARE.1],
                "facet_level": [frontlit::FACET_LEVEL.0, frontlit::FACET_LEVEL.1],
                "band_level_of_contrast": [frontlit::BAND_LEVEL.0, frontlit::BAND_LEVEL.1],
                "edge_facet_share": frontlit::EDGE_FACET_SHARE,
                "highlight_level": [frontlit::HIGHLIGHT_LEVEL.0, frontlit::HIGHLIGHT_LEVEL.1],
                "shadow_offset_px": [frontlit::SHADOW_OFFSET_PX.0, frontlit::SHADOW_OFFSET_PX.1],
                "shadow_sigma_px": [frontlit::SHADOW_SIGMA_PX.0, frontlit::SHADOW_SIGMA_PX.1],
                "shadow_depth": [frontlit::SHADOW_DEPTH.0, frontlit::SHADOW_DEPTH.1],
            }),
            Effect::Large(p) => json!({
                "model": "paper = smooth lighting + texture - ink_depth * text - rule_depth * rules (lines of glyphs on ruled lines, the page turned by page_turn_deg); parts opaque at their level",
                "paper_level": p.level,
                "paper_lighting": p.lighting_amplitude,
                "texture_std": p.texture_std,
                "page_turn_deg": p.page_turn_deg,
                "glyph_px": p.glyph_px,
                "line_pitch_px": p.line_pitch_px,
                "ink_depth": p.ink_depth,
                "rule_depth": p.rule_depth,
                "ink_share": p.ink_share,
                "large_shares": LARGE_SHARES.iter().map(|(n, s)| json!({"class": n, "share": s})).collect::<Vec<_>>(),
                "dark_level": [large::DARK_LEVEL.0, large::DARK_LEVEL.1],
                "bright_level": [large::BRIGHT_LEVEL.0, large::BRIGHT_LEVEL.1],
                "dark_share": large::DARK_SHARE,
            }),
            Effect::Ideal => json!({}),
        };
        if let (Some(o), Some(p)) = (v.as_object_mut(), params.as_object()) {
            o.extend(p.clone());
        }
        if self.touching && !matches!(self.effect, Effect::Touching(_)) {
            v["touching_share"] = json!(touching::TOUCHING_SHARE);
            v["overlap_max"] = json!(touching::OVERLAP_MAX);
            v["just_touching"] = json!(touching::JUST_TOUCHING);
        }
        if self.variant.is_rods() {
            v["scale"] = json!([ROD_SCALE.0, ROD_SCALE.1]);
            v["stretch"] = json!([ROD_STRETCH.0, ROD_STRETCH.1]);
            v["head_scale"] = json!([ROD_HEAD.0, ROD_HEAD.1]);
            v["eye_scale"] = json!([ROD_EYE.0, ROD_EYE.1]);
        }
        v
    }

    /// A capture of the empty platform: lighting, blur, noise from stream `index`.
    fn background(&self, right: bool, index: u64) -> image::GrayImage {
        let mut img = if right {
            self.light_right.clone().unwrap_or_default()
        } else {
            self.light.clone()
        };
        blur(&mut img, self.w, self.h, BLUR_SIGMA);
        let mut rng = Rng::stream(self.seed, purpose::BACKGROUND, index + if right { 1000 } else { 0 });
        capture(&img, self.w, self.h, self.noise_sigma, &mut rng)
    }

    /// One camera's view of the placed parts before noise: lighting, drift, parts, blur (the
    /// right view shifts each part by its disparity).
    fn compose(&self, parts: &[Placed], right: bool, drift: &mut Rng) -> Vec<f64> {
        let (w, h) = (self.w, self.h);
        let mut img = if right {
            self.light_right.clone().unwrap_or_default()
        } else {
            self.light.clone()
        };
        add_drift(&mut img, w, h, drift, self.drift_max);
        // Front-lit: the lit mat without its texture (what the parts are lit by), then the
        // shadows on the mat, under every part.
        let lit = match &self.effect {
            Effect::Frontlit(f) => {
                let lit: Vec<f64> = img.iter().zip(&f.texture).map(|(v, t)| v - t).collect();
                let shadows: Vec<(&PartSpec, &raster::Pose, frontlit::Shadow)> = parts
                    .iter()
                    .filter_map(|p| match p.body {
                        Body::Frontlit(s) => Some((p.drawn(&self.cat), &p.pose, s)),
                        _ => None,
                    })
                    .collect();
                frontlit::cast_shadows(&mut img, w, h, &shadows);
                Some(lit)
            }
            _ => None,
        };
        // A part over another hides it: what lies beneath goes back to the platform first.
        let platform = self.touching.then(|| img.clone());
        for p in parts {
            let pose = if right {
                p.pose.shifted(-p.depth.map_or(0.0, |d| d.1))
            } else {
                p.pose
            };
            let spec = p.drawn(&self.cat);
            if let Some(base) = &platform {
                silhouette(spec, &pose, w, h).for_each(|x, y, c| {
                    let i = y as usize * w + x as usize;
                    img[i] -= c * (img[i] - base[i]);
                });
            }
            match (&self.effect, p.body) {
                (Effect::Lens(lens), _) => draw_part_through(&mut img, w, h, spec, &pose, &p.look, Some(lens)),
                (Effect::Thick(cam), Body::Thick { thickness_mm, wall }) => {
                    // Walls: the sweep less the top face; then the top face with its look.
                    let s = cam.scale(thickness_mm);
                    let top = cam.lift(&pose, s);
                    let sweep = cam.sweep(&pose.rings(spec.rings()), s);
                    coverage_union(&sweep, Some((w, h)), SUBROWS)
                        .for_each(|x, y, c| img[y as usize * w + x as usize] += c * wall);
                    silhouette(spec, &top, w, h).for_each(|x, y, c| img[y as usize * w + x as usize] -= c * wall);
                    draw_part(&mut img, w, h, spec, &top, &p.look);
                }
                (Effect::Paper { texture, .. }, _) => {
                    // The part hides the platform's texture.
                    draw_part(&mut img, w, h, spec, &pose, &p.look);
                    silhouette(spec, &pose, w, h).for_each(|x, y, c| {
                        let i = y as usize * w + x as usize;
                        img[i] -= c * texture[i];
                    });
                }
                (_, Body::Frontlit(_)) => {
                    if let Some(lit) = &lit {
                        frontlit::draw_metal(&mut img, lit, w, h, spec, &pose, &p.look);
                    }
                }
                (_, Body::Opaque { level }) => silhouette(spec, &pose, w, h).for_each(|x, y, c| {
                    let i = y as usize * w + x as usize;
                    img[i] += c * (level - img[i]);
                }),
                _ => draw_part(&mut img, w, h, spec, &pose, &p.look),
            }
        }
        blur(&mut img, w, h, BLUR_SIGMA);
        img
    }

    /// One camera's view with sensor noise from the frame's stream (`exposure`: after the
    /// frame's gain and offset).
    fn view(&self, parts: &[Placed], right: bool, index: u64, drift: &mut Rng) -> image::GrayImage {
        let mut img = self.compose(parts, right, drift);
        if let Some((gain, offset)) = self.exposure(index as usize) {
            img.iter_mut().for_each(|v| *v = gain * *v + offset);
        }
        let stream = if right {
            purpose::NOISE_RIGHT
        } else {
            purpose::NOISE_LEFT
        };
        capture(
            &img,
            self.w,
            self.h,
            self.noise_sigma,
            &mut Rng::stream(self.seed, stream, index),
        )
    }

    /// The scene frame `index` shows (`exposure`: two frames per scene).
    fn scene_of(&self, index: usize) -> usize {
        if matches!(self.effect, Effect::Exposure) {
            index / 2
        } else {
            index
        }
    }

    /// Gain and offset of frame `index` (`exposure` sets only): the second frame of a scene
    /// draws its gain again until it is [`EXPOSURE_GAIN_STEP`] or more from the first's.
    fn exposure(&self, index: usize) -> Option<(f64, f64)> {
        if !matches!(self.effect, Effect::Exposure) {
            return None;
        }
        let gain = |r: &mut Rng| r.range(EXPOSURE_GAIN.0, EXPOSURE_GAIN.1);
        let mut rng = Rng::stream(self.seed, purpose::EXPOSURE, index as u64);
        let mut g = gain(&mut rng);
        if index % 2 == 1 {
            let first = gain(&mut Rng::stream(self.seed, purpose::EXPOSURE, index as u64 - 1));
            while (g - first).abs() < EXPOSURE_GAIN_STEP {
                g = gain(&mut rng);
            }
        }
        Some((g, rng.range(EXPOSURE_OFFSET.0, EXPOSURE_OFFSET.1)))
    }

    /// What a variant adds to the planned parts of scene `scene` (thickness, print, opaque
    /// level), from a stream of its own.
    fn finish_parts(&self, parts: &mut [Placed], scene: usize) {
        let mut rng = Rng::stream(self.seed, purpose::EFFECT_SCENE, scene as u64);
        for p in parts.iter_mut() {
            let varied = p.varied.clone();
            let spec = varied.as_ref().map_or(&self.cat[p.spec], |v| &v.spec);
            match &self.effect {
                Effect::Thick(_) => {
                    let thickness_mm = rng.range(THICKNESS_MM.0, THICKNESS_MM.1);
                    let c = p.look.contrast;
                    let wall = c.signum() * (c.abs() * rng.range(0.75, 1.0)).max(self.scene.min_contrast);
                    p.body = Body::Thick { thickness_mm, wall };
                }
                Effect::Backlit(b) => {
                    let level = rng.range(BACKLIT_PART_LEVEL.0, BACKLIT_PART_LEVEL.1);
                    p.look = Appearance {
                        contrast: level - b.at([p.pose.cx, p.pose.cy]),
                        texture: Texture::Plain,
                    };
                    p.body = Body::Opaque { level };
                }
                Effect::Frontlit(light) => {
                    let (look, body) = frontlit::dress(&mut rng, spec, &p.pose, light);
                    p.look = look;
                    p.body = body;
                }
                Effect::Flipped(chiral)
                    if chiral.get(p.spec).copied().unwrap_or(false) && rng.chance(FLIPPED_SHARE) =>
                {
                    self.lay_upside_down(p);
                }
                Effect::Printed => {
                    let printed = rng
                        .chance(print::PRINTED_SHARE)
                        .then(|| print::print(&mut rng, spec, p.pose.k, p.look.contrast));
                    if let Some(t) = printed.flatten() {
                        p.look.texture = t;
                    }
                }
                _ => {}
            }
        }
    }

    /// Lays part `p` upside down (drawn as its mirror image), unless that would take it
    /// nearer the frame's edge than the margin (the mirror image's bounds differ).
    fn lay_upside_down(&self, p: &mut Placed) {
        let mirrored = p.drawn(&self.cat).mirrored();
        let b = bounds(&p.pose.rings(mirrored.rings()));
        let (w, h) = (self.w as f64, self.h as f64);
        let m = scene::INSIDE_MARGIN_PX;
        if b[0] >= m && b[1] >= m && b[2] <= w - 1.0 - m && b[3] <= h - 1.0 - m {
            p.varied = Some(Arc::new(shapes::Varied {
                spec: mirrored,
                stretch: 1.0,
                factors: Vec::new(),
            }));
            p.flipped = true;
            p.look.texture = p.look.texture.mirrored();
        }
    }

    /// The parts of a scene, from the scene's layout stream (`large`: its own planner).
    fn plan(&self, rng: &mut Rng) -> Vec<Placed> {
        match &self.effect {
            Effect::Large(paper) => large::plan(rng, &self.cat, &self.scene, paper),
            _ => plan(rng, &self.cat, &self.scene),
        }
    }

    /// Plans, renders and writes frame `index`; its truth.
    fn frame(&self, frames_dir: &Path, index: usize, name: &str) -> Result<Vec<PartJson>, GenError> {
        let scene = self.scene_of(index);
        let mut rng = Rng::stream(self.seed, purpose::LAYOUT, scene as u64);
        let mut parts = self.plan(&mut rng);
        if let Effect::Touching(chiral) = &self.effect {
            // Upside down before they are moved together: the mirror image is what touches.
            let mut flips = Rng::stream(self.seed, purpose::TOUCHING_FLIP, scene as u64);
            for p in parts.iter_mut() {
                if chiral.get(p.spec).copied().unwrap_or(false) && flips.chance(FLIPPED_SHARE) {
                    self.lay_upside_down(p);
                }
            }
        }
        if self.touching {
            let mut fx = Rng::stream(self.seed, purpose::EFFECT_SCENE, scene as u64);
            touching::bring_together(&mut fx, &self.cat, &mut parts, self.w, self.h);
        }
        self.finish_parts(&mut parts, scene);
        if self.scene.stereo.is_some() {
            let left = self.view(&parts, false, index as u64, &mut rng);
            let right = self.view(&parts, true, index as u64, &mut rng);
            output::write_png(&frames_dir.join(format!("left_{name}")), &left)?;
            output::write_png(&frames_dir.join(format!("right_{name}")), &right)?;
        } else {
            let img = self.view(&parts, false, index as u64, &mut rng);
            output::write_png(&frames_dir.join(name), &img)?;
        }
        Ok(parts.iter().map(|p| self.truth(p, index)).collect())
    }

    /// The truth record of a placed part in frame `index`.
    fn truth(&self, p: &Placed, index: usize) -> PartJson {
        let spec = p.drawn(&self.cat);
        let mut t = truth_entry(spec, p);
        let mut put = |k: &str, v: serde_json::Value| {
            t.extra.insert(k.to_string(), v);
        };
        match (&self.effect, p.body) {
            (Effect::Lens(lens), _) => {
                let c = [p.pose.cx, p.pose.cy];
                let d = lens.distort(c);
                let rings = p.pose.rings(spec.rings());
                let (area, ac) = raster::moments(&lens.warp(&rings));
                let (rot, scale) = lens.border_fit(&rings);
                put("x_undistorted", json!(c[0]));
                put("y_undistorted", json!(c[1]));
                put("angle_drawn_deg", json!(p.angle_deg));
                put("lens_rotation_deg", json!(rot));
                put("lens_scale", json!(scale));
                put("area_x", json!(ac[0]));
                put("area_y", json!(ac[1]));
                put("area_px", json!(area));
                t.x = d[0];
                t.y = d[1];
                t.angle_deg = wrap_deg(p.angle_deg + rot);
            }
            (Effect::Thick(cam), Body::Thick { thickness_mm, wall }) => {
                let s = cam.scale(thickness_mm);
                let top = cam.lift(&p.pose, s);
                put("thickness_mm", json!(thickness_mm));
                put("top_scale", json!(s));
                put("bottom_x", json!(p.pose.cx));
                put("bottom_y", json!(p.pose.cy));
                put("wall_contrast", json!(wall));
                put("scale", json!(p.scale * s));
                t.x = top.cx;
                t.y = top.cy;
            }
            (_, Body::Opaque { level }) => put("level", json!(level)),
            (Effect::Frontlit(light), Body::Frontlit(s)) => {
                put("light_from_deg", json!(light.from_deg));
                put("shadow_dx", json!(s.offset[0]));
                put("shadow_dy", json!(s.offset[1]));
                put("shadow_sigma", json!(s.sigma));
                put("shadow_depth", json!(s.depth));
                if p.look.contrast < 0.0 {
                    put("dark", json!(true));
                }
                if let Texture::Metal(m) = &p.look.texture {
                    put("facet", json!(if m.facet.edge { "edge" } else { "band" }));
                    put("facet_share", json!(m.facet.share));
                    put("facet_level", json!(m.facet.level));
                    put("highlights", json!(m.highlights.len()));
                }
            }
            _ => {}
        }
        if let Effect::Flipped(chiral) | Effect::Touching(chiral) = &self.effect {
            if spec.is_template {
                put("chiral", json!(chiral.get(p.spec).copied().unwrap_or(false)));
            }
            t.flipped = p.flipped.then_some(true);
        }
        if let Some((gain, offset)) = self.exposure(index) {
            put("gain", json!(gain));
            put("offset", json!(offset));
            put("scene", json!(self.scene_of(index)));
        }
        if let Texture::Print { marks } = &p.look.texture {
            let ink = marks.iter().filter(|m| m.ink).count();
            put("print_marks", json!(ink));
            put("print_patches", json!(marks.len() - ink));
        }
        if self.scene.vary {
            // The drawn part's own proportions over the template's (1: a part that does not vary).
            put("stretch", json!(p.varied.as_ref().map_or(1.0, |v| v.stretch)));
            for (k, f) in p.varied.iter().flat_map(|v| v.factors.iter()) {
                put(k, json!(f));
            }
        }
        t
    }
}

/// An angle in degrees brought into [0, 360).
fn wrap_deg(a: f64) -> f64 {
    let r = a.rem_euclid(360.0);
    if r >= 360.0 {
        0.0
    } else {
        r
    }
}

/// The truth record of a placed part (the ideal camera).
fn truth_entry(spec: &PartSpec, p: &Placed) -> PartJson {
    let mut extra = BTreeMap::new();
    extra.insert("scale".to_string(), json!(p.scale));
    extra.insert("contrast".to_string(), json!(p.look.contrast));
    extra.insert("texture".to_string(), json!(p.look.texture.name()));
    extra.insert("shape".to_string(), json!(spec.name));
    if p.partial || p.touching {
        extra.insert("visible_fraction".to_string(), json!(p.visible));
    }
    if let Some((z, d)) = p.depth {
        extra.insert("z_mm".to_string(), json!(z));
        extra.insert("disparity_px".to_string(), json!(d));
    }
    // The shape's centroid is its origin, so the drawn centroid is the pose's centre.
    let c = p.pose.apply([0.0, 0.0]);
    PartJson {
        class: spec.is_template.then(|| spec.name.to_string()),
        x: c[0],
        y: c[1],
        angle_deg: p.angle_deg,
        symmetry: Some(spec.symmetry),
        score: None,
        partial: p.partial.then_some(true),
        flipped: None,
        touching: p.touching.then_some(true),
        extra,
    }
}

/// Frame file names: `f000.png`, … (wider when there are more than 1000).
fn frame_name(index: usize, count: usize) -> String {
    let digits = count.saturating_sub(1).to_string().len().max(3);
    format!("f{index:0digits$}.png")
}

/// Writes a fixture set to `out` (created with its subfolders when missing; files already there
/// are overwritten, others are left alone).
///
/// # Errors
/// Options out of range, or a folder or file that cannot be written ([`GenError`] names it).
pub fn generate(out: &Path, opts: &GenOptions) -> Result<GenSummary, GenError> {
    for (what, v) in [("width", opts.width), ("height", opts.height)] {
        if !(32..=16384).contains(&v) {
            return Err(GenError::Options(format!("{what} {v} px is out of range (32–16384)")));
        }
    }
    let set = SetPlan::new(opts);
    let cat = &set.cat;
    let stereo = opts.variant == Variant::Stereo;
    let with_background = opts.writes_background();
    let frames_dir = out.join("frames");
    let templates_dir = out.join("templates");
    for d in [out, &frames_dir, &templates_dir] {
        output::create_dir(d)?;
    }
    if with_background {
        output::create_dir(&out.join("backgrounds"))?;
        if stereo {
            output::create_dir(&out.join("backgrounds_right"))?;
        }
    }

    // Templates and the catalogue.
    let mut parts_json = Vec::new();
    for spec in cat {
        let mut entry = json!({
            "class": spec.name,
            "template": spec.is_template,
            "symmetry": spec.symmetry,
            "area_mm2": spec.area_mm2(),
        });
        if spec.is_template {
            let (img, c) = template(spec, set.scene.px_per_mm);
            let file = format!("templates/{}.png", spec.name);
            output::write_png(&out.join(&file), &img)?;
            entry["file"] = json!(file);
            entry["centroid_px"] = json!(c);
        }
        parts_json.push(entry);
    }
    output::write_json(
        &out.join("parts.json"),
        &json!({ "px_per_mm": set.scene.px_per_mm, "parts": parts_json }),
    )?;
    if opts.variant.is_real_camera() {
        output::write_json(&out.join("variant.json"), &set.describe(with_background))?;
    }
    if let Some(config) = opts.variant.set_config() {
        let path = out.join("vorl.toml");
        std::fs::write(&path, config).map_err(|source| GenError::Io { path, source })?;
    }

    // The empty platform.
    if with_background {
        let mut jobs: Vec<(PathBuf, bool, u64)> = vec![(out.join("background.png"), false, 0)];
        if stereo {
            jobs.push((out.join("background_left.png"), false, 0));
            jobs.push((out.join("background_right.png"), true, 0));
        }
        for k in 0..BACKGROUND_CAPTURES {
            let file = format!("bg_{k:02}.png");
            jobs.push((out.join("backgrounds").join(&file), false, k as u64 + 1));
            if stereo {
                jobs.push((out.join("backgrounds_right").join(&file), true, k as u64 + 1));
            }
        }
        jobs.par_iter()
            .try_for_each(|(path, right, index)| output::write_png(path, &set.background(*right, *index)))?;
    }

    // Frames.
    let truths: Vec<Vec<PartJson>> = (0..opts.frames)
        .into_par_iter()
        .map(|i| set.frame(&frames_dir, i, &frame_name(i, opts.frames)))
        .collect::<Result<_, _>>()?;
    let mut summary = GenSummary {
        frames: opts.frames,
        parts: 0,
        known_parts: 0,
        unknown_parts: 0,
        partial_parts: 0,
        classes: cat
            .iter()
            .filter(|s| s.is_template)
            .map(|s| s.name.to_string())
            .collect(),
    };
    let mut truth = FramesJson::default();
    for (i, parts) in truths.into_iter().enumerate() {
        summary.parts += parts.len();
        summary.known_parts += parts.iter().filter(|p| p.class.is_some()).count();
        summary.unknown_parts += parts.iter().filter(|p| p.class.is_none()).count();
        summary.partial_parts += parts.iter().filter(|p| p.partial == Some(true)).count();
        truth.frames.insert(frame_name(i, opts.frames), parts);
    }
    output::write_json(&out.join("truth.json"), &truth)?;
    if opts.variant.writes_teach() {
        // The part as drawn: its catalogue shape at its truth pose.
        let point = |p: &PartJson| {
            let shape = p.extra.get("shape").and_then(|v| v.as_str());
            let scale = p.extra.get("scale").and_then(serde_json::Value::as_f64).unwrap_or(1.0);
            match cat.iter().find(|s| Some(s.name) == shape) {
                Some(spec) => output::teach_point(
                    spec,
                    &raster::Pose::new(p.x, p.y, p.angle_deg, set.scene.px_per_mm * scale),
                ),
                None => [p.x, p.y],
            }
        };
        output::write_teach(&out.join("teach.json"), &summary.classes, &truth, point)?;
    }
    if stereo {
        output::write_json(
            &out.join("camera.json"),
            &json!({
                "f_px": STEREO_F_PX,
                "baseline_mm": STEREO_BASELINE_MM,
                "cx": (f64::from(opts.width) - 1.0) / 2.0,
                "cy": (f64::from(opts.height) - 1.0) / 2.0,
                "platform_z_mm": STEREO_PLATFORM_Z_MM,
                "platform_disparity_px": STEREO_F_PX * STEREO_BASELINE_MM / STEREO_PLATFORM_Z_MM,
            }),
        )?;
    }
    Ok(summary)
}

/// A set made in memory, frame by frame, without files (long runs: `vorl soak`). The images
/// are those [`generate`] writes for the same options (stereo: the left view only).
pub struct MemorySet {
    plan: SetPlan,
    background: bool,
}

impl MemorySet {
    /// The set of these options.
    ///
    /// # Errors
    /// Options out of range.
    pub fn new(opts: &GenOptions) -> Result<Self, GenError> {
        for (what, v) in [("width", opts.width), ("height", opts.height)] {
            if !(32..=16384).contains(&v) {
                return Err(GenError::Options(format!("{what} {v} px is out of range (32–16384)")));
            }
        }
        Ok(MemorySet {
            plan: SetPlan::new(opts),
            background: opts.writes_background(),
        })
    }

    /// The template silhouettes (class, image), in catalogue order.
    pub fn templates(&self) -> Vec<(String, image::GrayImage)> {
        self.plan
            .cat
            .iter()
            .filter(|s| s.is_template)
            .map(|s| (s.name.to_string(), template(s, self.plan.scene.px_per_mm).0))
            .collect()
    }

    /// The captures of the empty platform (`background.png` and `backgrounds/`), or none when
    /// the set has no background.
    pub fn backgrounds(&self) -> Vec<image::GrayImage> {
        if !self.background {
            return Vec::new();
        }
        (0..=BACKGROUND_CAPTURES as u64)
            .map(|k| self.plan.background(false, k))
            .collect()
    }

    /// Frame `index` (the left view of a stereo pair) and its truth.
    pub fn frame(&self, index: usize) -> (image::GrayImage, Vec<PartJson>) {
        let set = &self.plan;
        let scene = set.scene_of(index);
        let mut rng = Rng::stream(set.seed, purpose::LAYOUT, scene as u64);
        let mut parts = set.plan(&mut rng);
        set.finish_parts(&mut parts, scene);
        let img = set.view(&parts, false, index as u64, &mut rng);
        let truth = parts.iter().map(|p| set.truth(p, index)).collect();
        (img, truth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh scratch folder under the system temp folder.
    pub(super) fn scratch(name: &str) -> PathBuf {
        let p = std::env::temp_dir().join(format!("vorl-gen-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        p
    }

    /// All files under `root`, relative, sorted, with their bytes.
    pub(super) fn files(root: &Path) -> Vec<(PathBuf, Vec<u8>)> {
        let mut out = Vec::new();
        let mut stack = vec![root.to_path_buf()];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).expect("read dir") {
                let p = e.expect("entry").path();
                if p.is_dir() {
                    stack.push(p);
                } else {
                    let bytes = std::fs::read(&p).expect("read");
                    out.push((p.strip_prefix(root).expect("prefix").to_path_buf(), bytes));
                }
            }
        }
        out.sort();
        out
    }

    /// The in-memory set gives the images `vorl gen` writes: frames (stereo: the left view),
    /// backgrounds and templates, and the truth.
    #[test]
    fn memory_set_is_what_generate_writes() {
        for variant in [Variant::Exposure, Variant::Stereo, Variant::Backlit, Variant::Frontlit] {
            let opts = GenOptions {
                seed: 5,
                frames: 3,
                variant,
                width: 320,
                height: 240,
                background: None,
            };
            let dir = scratch(&format!("memory-{variant}"));
            generate(&dir, &opts).unwrap();
            let set = MemorySet::new(&opts).unwrap();
            let truth: FramesJson = serde_json::from_slice(&std::fs::read(dir.join("truth.json")).unwrap()).unwrap();
            for i in 0..3 {
                let name = frame_name(i, 3);
                let file = if variant == Variant::Stereo {
                    format!("left_{name}")
                } else {
                    name.clone()
                };
                let (img, parts) = set.frame(i);
                assert!(img == gray(&dir.join("frames").join(file)), "{variant} frame {i}");
                assert_eq!(parts.len(), truth.frames[&name].len(), "{variant} frame {i}");
            }
            let backgrounds = set.backgrounds();
            assert_eq!(backgrounds.is_empty(), !variant.writes_background(), "{variant}");
            if let Some(first) = backgrounds.first() {
                assert!(*first == gray(&dir.join("background.png")), "{variant}");
                assert!(backgrounds[1] == gray(&dir.join("backgrounds/bg_00.png")), "{variant}");
                assert_eq!(backgrounds.len(), BACKGROUND_CAPTURES + 1);
            }
            for (class, img) in set.templates() {
                assert!(
                    img == gray(&dir.join(format!("templates/{class}.png"))),
                    "{variant} {class}"
                );
            }
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    pub(super) fn gray(path: &Path) -> image::GrayImage {
        image::open(path).expect("open png").to_luma8()
    }

    /// Compares each part's silhouette in a frame (|frame − background| over a threshold) with
    /// the part drawn from its truth (shape, x, y, angle, scale) inside its bounding circle + 3 px,
    /// leaving out pixels within ¾ px of the border; the worst share of pixels that disagree.
    pub(super) fn worst_disagreement(
        frame: &image::GrayImage,
        bg: &image::GrayImage,
        parts: &[PartJson],
        right: bool,
    ) -> f64 {
        let cat: Vec<PartSpec> = catalogue().into_iter().chain(sharp_catalogue()).collect();
        let mut worst: f64 = 0.0;
        for p in parts {
            let shape = p.extra["shape"].as_str().expect("shape");
            let spec = cat.iter().find(|s| s.name == shape).expect("shape in catalogue");
            assert_eq!(p.class.is_some(), spec.is_template);
            let scale = p.extra["scale"].as_f64().expect("scale");
            // Half the contrast, at most 15 (labels and shading stay ≥ 30 from the platform).
            let threshold = (p.extra["contrast"].as_f64().expect("contrast").abs() / 2.0).min(15.0);
            let shift = if right {
                p.extra["disparity_px"].as_f64().expect("disparity")
            } else {
                0.0
            };
            let pose = raster::Pose::new(p.x - shift, p.y, p.angle_deg, scale);
            let r = spec.radius_mm() * scale + 3.0;
            let (mut n, mut bad) = (0usize, 0usize);
            for y in (p.y - r).floor() as i64..=(p.y + r).ceil() as i64 {
                for x in (pose.cx - r).floor() as i64..=(pose.cx + r).ceil() as i64 {
                    let outside_circle = (x as f64 - pose.cx).hypot(y as f64 - pose.cy) > r;
                    if outside_circle
                        || x < 0
                        || y < 0
                        || x >= i64::from(frame.width())
                        || y >= i64::from(frame.height())
                    {
                        continue;
                    }
                    let inside = |ox: f64, oy: f64| {
                        let q = pose.invert([x as f64 + ox, y as f64 + oy]);
                        spec.coverage(q[0], q[1])
                    };
                    let want = inside(0.0, 0.0);
                    if [(-0.75, -0.75), (0.75, -0.75), (-0.75, 0.75), (0.75, 0.75)]
                        .iter()
                        .any(|&(a, b)| inside(a, b) != want)
                    {
                        continue;
                    }
                    let diff = (f64::from(frame.get_pixel(x as u32, y as u32).0[0])
                        - f64::from(bg.get_pixel(x as u32, y as u32).0[0]))
                    .abs();
                    let got = diff > threshold;
                    if want || got {
                        n += 1;
                        bad += usize::from(want != got);
                    }
                }
            }
            worst = worst.max(bad as f64 / n as f64);
        }
        worst
    }

    #[test]
    fn gen_partial_volume_centroid_of_a_clean_frame_matches_truth() {
        // A frame without noise or drift: the centroid of (image − platform) / contrast over a
        // plain part's neighbourhood is the truth centroid (blur keeps centroids).
        let opts = GenOptions {
            seed: 21,
            ..GenOptions::default()
        };
        let mut set = SetPlan::new(&opts);
        set.drift_max = 0.0;
        let cat = set.cat.clone();
        let mut light = set.light.clone();
        blur(&mut light, set.w, set.h, BLUR_SIGMA);
        let mut checked = 0;
        for index in 0..12 {
            let mut rng = Rng::stream(opts.seed, purpose::LAYOUT, index);
            let parts = plan(&mut rng, &cat, &set.scene);
            let img = set.compose(&parts, false, &mut rng);
            for p in parts.iter().filter(|p| p.look.texture == render::Texture::Plain) {
                // Inside the bounding circle + 4 px: all of this part's blurred edge, none of another part.
                let r = cat[p.spec].radius_mm() * p.pose.k + 4.0;
                let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
                let (y0, y1) = (
                    (p.pose.cy - r).floor().max(0.0) as usize,
                    ((p.pose.cy + r).ceil() as usize).min(set.h - 1),
                );
                let (x0, x1) = (
                    (p.pose.cx - r).floor().max(0.0) as usize,
                    ((p.pose.cx + r).ceil() as usize).min(set.w - 1),
                );
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        if (x as f64 - p.pose.cx).hypot(y as f64 - p.pose.cy) > r {
                            continue;
                        }
                        let i = y * set.w + x;
                        let v = (img[i] - light[i]) / p.look.contrast;
                        s += v;
                        sx += v * x as f64;
                        sy += v * y as f64;
                    }
                }
                let t = truth_entry(&cat[p.spec], p);
                let err = (sx / s - t.x).hypot(sy / s - t.y);
                assert!(err < 0.02, "{}: {err} px", cat[p.spec].name);
                checked += 1;
            }
        }
        assert!(checked >= 5);
    }

    #[test]
    fn gen_variant_names_parse() {
        for v in Variant::ALL {
            assert_eq!(v.name().parse::<Variant>(), Ok(v));
            assert_eq!(v.to_string(), v.name());
        }
        let e = "fancy".parse::<Variant>().unwrap_err();
        assert!(
            e.contains(
                "default, noisy, small, border, stereo, sharp, lens, thick, exposure, paper, printed, backlit, rods"
            ),
            "{e}"
        );
    }

    #[test]
    fn gen_same_seed_same_bytes() {
        let opts = GenOptions {
            seed: 9,
            frames: 2,
            variant: Variant::Small,
            width: 160,
            height: 120,
            background: None,
        };
        let (a, b, c) = (scratch("det-a"), scratch("det-b"), scratch("det-c"));
        let sa = generate(&a, &opts).expect("generate a");
        let sb = generate(&b, &opts).expect("generate b");
        generate(
            &c,
            &GenOptions {
                seed: 10,
                ..opts.clone()
            },
        )
        .expect("generate c");
        assert_eq!(sa, sb);
        assert!(sa.parts >= 2, "{sa:?}");
        let (fa, fb, fc) = (files(&a), files(&b), files(&c));
        assert!(fa.len() >= 2 + 1 + BACKGROUND_CAPTURES + 13 + 2);
        assert_eq!(fa, fb);
        let truth = |f: &[(PathBuf, Vec<u8>)]| {
            f.iter()
                .find(|(p, _)| p == Path::new("truth.json"))
                .expect("truth")
                .1
                .clone()
        };
        assert_ne!(truth(&fa), truth(&fc));
        for d in [a, b, c] {
            let _ = std::fs::remove_dir_all(d);
        }
    }

    #[test]
    fn gen_default_set_matches_its_truth() {
        let dir = scratch("default");
        let opts = GenOptions {
            seed: 3,
            frames: 4,
            ..GenOptions::default()
        };
        let s = generate(&dir, &opts).expect("generate");
        assert_eq!(s.frames, 4);
        assert_eq!(s.known_parts + s.unknown_parts, s.parts);
        assert_eq!(s.partial_parts, 0);
        let truth = FramesJson::load(&dir.join("truth.json")).expect("truth loads");
        assert_eq!(
            truth.frames.keys().cloned().collect::<Vec<_>>(),
            vec!["f000.png", "f001.png", "f002.png", "f003.png"]
        );
        let bg = gray(&dir.join("background.png"));
        assert_eq!(bg.dimensions(), (640, 480));
        let mean = bg.pixels().map(|p| f64::from(p.0[0])).sum::<f64>() / (640.0 * 480.0);
        assert!((110.0..=150.0).contains(&mean), "{mean}");
        for (name, parts) in &truth.frames {
            assert!((2..=5).contains(&parts.len()));
            for p in parts {
                assert!((0.0..360.0).contains(&p.angle_deg));
                assert!(p.partial.is_none());
            }
            let frame = gray(&dir.join("frames").join(name));
            let worst = worst_disagreement(&frame, &bg, parts, false);
            assert!(worst < 0.005, "{name}: {worst}");
        }
        let t = gray(&dir.join("templates").join("gear_z12.png"));
        assert!(t.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255));
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn gen_border_variant_marks_partial_parts() {
        let dir = scratch("border");
        let opts = GenOptions {
            seed: 5,
            frames: 8,
            variant: Variant::Border,
            ..GenOptions::default()
        };
        let s = generate(&dir, &opts).expect("generate");
        assert!(s.partial_parts >= 3, "{s:?}");
        let truth = FramesJson::load(&dir.join("truth.json")).expect("truth loads");
        let cat = catalogue();
        let mut partial = 0;
        for parts in truth.frames.values() {
            for p in parts {
                // "partial" is written only when true.
                assert_ne!(p.partial, Some(false));
                let is_partial = p.partial == Some(true);
                partial += usize::from(is_partial);
                assert_eq!(p.extra.contains_key("visible_fraction"), is_partial);
                if let Some(class) = &p.class {
                    let spec = cat.iter().find(|s| s.name == class).expect("class");
                    let scale = p.extra["scale"].as_f64().expect("scale");
                    let pose = raster::Pose::new(p.x, p.y, p.angle_deg, scale);
                    let b = raster::bounds(&pose.rings(spec.rings()));
                    let cut = b[0] < -0.5 || b[1] < -0.5 || b[2] > 639.5 || b[3] > 479.5;
                    assert_eq!(cut, is_partial);
                }
            }
        }
        assert_eq!(partial, s.partial_parts);
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn gen_stereo_disparity_is_f_b_over_z() {
        let dir = scratch("stereo");
        let opts = GenOptions {
            seed: 11,
            frames: 3,
            variant: Variant::Stereo,
            ..GenOptions::default()
        };
        generate(&dir, &opts).expect("generate");
        let cam: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("camera.json")).expect("camera")).expect("json");
        let (f, b) = (
            cam["f_px"].as_f64().expect("f"),
            cam["baseline_mm"].as_f64().expect("b"),
        );
        assert_eq!(
            (f, b, cam["cx"].as_f64(), cam["cy"].as_f64()),
            (800.0, 60.0, Some(319.5), Some(239.5))
        );
        let z0 = cam["platform_z_mm"].as_f64().expect("z0");
        let truth = FramesJson::load(&dir.join("truth.json")).expect("truth loads");
        let bg_l = gray(&dir.join("background_left.png"));
        let bg_r = gray(&dir.join("background_right.png"));
        assert_eq!(
            std::fs::read(dir.join("background.png")).ok(),
            std::fs::read(dir.join("background_left.png")).ok()
        );
        for (name, parts) in &truth.frames {
            for p in parts {
                let z = p.extra["z_mm"].as_f64().expect("z");
                let d = p.extra["disparity_px"].as_f64().expect("d");
                assert!((z0 - 60.0..=z0 - 5.0).contains(&z));
                assert!((d - f * b / z).abs() < 1e-9);
                assert!((p.extra["scale"].as_f64().expect("scale") - z0 / z).abs() < 1e-12);
            }
            let left = gray(&dir.join("frames").join(format!("left_{name}")));
            let right = gray(&dir.join("frames").join(format!("right_{name}")));
            assert!(worst_disagreement(&left, &bg_l, parts, false) < 0.005);
            assert!(worst_disagreement(&right, &bg_r, parts, true) < 0.005);
        }
        let _ = std::fs::remove_dir_all(dir);
    }
}
