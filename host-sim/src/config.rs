//! Pipeline parameters on the host: flags, a TOML file, and `vorl config --defaults`.

use serde::{Deserialize, Serialize};
use vorl_core::pixels::mask::{Cleanup, Polarity, Threshold};
use vorl_core::{AngleEstimator, Params, Position, Refine};

/// The parameters as they appear in a TOML config file. Every field is optional in the file;
/// missing ones keep their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Weight of intensity against gradient in I' = α·I + (1−α)·|∇I| (eq. 3.1), 0..1.
    pub alpha: f32,
    /// Foreground threshold on |I' − B|: a number 0..255, or "otsu".
    pub threshold: ThresholdSetting,
    /// Which parts are foreground: "either" (darker or brighter than the platform), "darker"
    /// or "brighter" (a shadow beside a brighter part is then not part of it).
    pub polarity: PolaritySetting,
    /// 3×3 clean-up of the foreground mask: "off", "open" or "open-close".
    pub cleanup: CleanupSetting,
    /// Fewest border points of a kept contour.
    pub min_points: usize,
    /// Smallest area of a kept contour, px².
    pub min_area: f32,
    /// Points a part contour is resampled to (n).
    pub n: usize,
    /// Points a template contour is resampled to (m, n ≤ m < 2n).
    pub m: usize,
    /// Neighbourhood k of the descriptor's angle term (eq. 4.2), in part points.
    pub k: usize,
    /// Weight ω of the angle term in c = ω·a + (1−ω)·d (eq. 4.3), 0..1.
    pub omega: f32,
    /// Decision threshold ε: a part is known iff f' < ε (eq. 5.2).
    pub epsilon: f32,
    /// Rotation estimator when the pose is not refined: "signed" (full circle) or "paper".
    pub angle: AngleSetting,
    /// After the DP: "off" (the paper's path), "pose" (align the pose only), "verify" (align and
    /// verify the best candidates; default).
    pub refine: RefineSetting,
    /// Candidates aligned and verified per part (refine = "verify"), 1..8.
    pub candidates: usize,
    /// Templates are searched in ascending order of their sorted-value bound; one is a candidate
    /// only if its DP cost is below this multiple of the lowest cost before it (≥ 1; inf: the
    /// first `candidates` of that order).
    pub candidate_ratio: f32,
    /// Verification threshold in px: unknown at or above the larger of it and
    /// verify_relative × the part's size.
    pub verify_threshold: f32,
    /// Verification threshold relative to the part's size (√(area/π) of its template times the
    /// aligned scale): the same meaning for small and large parts and any camera resolution.
    pub verify_relative: f32,
    /// Largest uniform offset of the outline along its normals that the alignment fits, relative
    /// to the part's size (thick parts under a close lens, blur, exposure); 0: none.
    pub offset_relative: f32,
    /// Smallest accepted part size over template size (camera height, lens, part variation).
    pub scale_min: f32,
    /// Largest accepted part size over template size.
    pub scale_max: f32,
    /// Position: "polygon" (the paper's border centroid), "partial-volume", or "pose".
    pub position: PositionSetting,
    /// With an empty shot: "fit" each frame's gain and offset against it on the platform's
    /// pixels and undo them before the frame is processed (default), or keep the frame
    /// "fixed". Without one the platform is estimated from the frames, exposure included.
    pub exposure: ExposureSetting,
    /// Without an empty shot: most frames one platform estimate serves (its own included)
    /// while they still fit it — the same exposure, no larger spread of the platform's
    /// residuals; a frame that does not is estimated anew. 1: every frame is estimated.
    pub platform_every: u32,
    /// Whether an outer border inside a hole of another part (print, a label, a small part in
    /// a ring) is a part of its own (else it is reported as a skip).
    pub nested_parts: bool,
    /// Whether parts may lie upside down: chiral templates' mirror images are matched too, and
    /// a part that fits one is reported `flipped`. false for a feeder that never flips parts.
    pub flipped_parts: bool,
    /// Whether blobs whose border is not one template's are searched for the parts along them
    /// (touching, overlapping and cut parts); a blob inside the frame whose border has no
    /// junction where two outlines could meet is left whole unsearched.
    pub touching_parts: bool,
}

/// Default of [`Config::platform_every`].
pub const DEFAULT_PLATFORM_EVERY: u32 = vorl_core::pixels::background::DEFAULT_KEEP_FRAMES;

/// `exposure` as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ExposureSetting {
    /// The frame's gain and offset fitted against the empty shot and undone.
    Fit,
    /// The frame as it is.
    Fixed,
}

/// `polarity` as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PolaritySetting {
    /// Parts darker or brighter than the platform.
    Either,
    /// Parts darker than the platform.
    Darker,
    /// Parts brighter than the platform (their shadows are not part of them).
    Brighter,
}

impl PolaritySetting {
    /// The core's polarity.
    pub fn to_core(self) -> Polarity {
        match self {
            PolaritySetting::Either => Polarity::Either,
            PolaritySetting::Darker => Polarity::Darker,
            PolaritySetting::Brighter => Polarity::Brighter,
        }
    }

    /// The setting of a core polarity.
    pub fn from_core(p: Polarity) -> Self {
        match p {
            Polarity::Either => PolaritySetting::Either,
            Polarity::Darker => PolaritySetting::Darker,
            Polarity::Brighter => PolaritySetting::Brighter,
        }
    }
}

/// `cleanup` as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum CleanupSetting {
    /// None.
    Off,
    /// Opening.
    Open,
    /// Opening then closing.
    OpenClose,
}

/// `refine` as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum RefineSetting {
    /// The paper's path.
    Off,
    /// Aligned pose, the paper's decision.
    Pose,
    /// Aligned and verified candidates.
    Verify,
}

/// `position` as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PositionSetting {
    /// Border polygon centroid (the paper's).
    Polygon,
    /// Partial-volume centroid.
    PartialVolume,
    /// Template centroid through the aligned pose.
    Pose,
}

/// Threshold as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ThresholdSetting {
    /// A fixed τ.
    Fixed(u8),
    /// `"otsu"`.
    Named(ThresholdName),
}

/// The named threshold methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThresholdName {
    /// Otsu's level per frame.
    Otsu,
}

/// Angle estimator as written in a config file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AngleSetting {
    /// Signed least-squares rotation, 0–360°.
    Signed,
    /// The paper's unsigned mean arccos (eq. 6.4).
    Paper,
}

impl Default for Config {
    fn default() -> Self {
        Config::from_params(&Params::DEFAULT)
    }
}

impl Config {
    /// The config that gives `p`.
    pub fn from_params(p: &Params) -> Self {
        Config {
            alpha: p.alpha,
            threshold: match p.threshold {
                Threshold::Fixed(t) => ThresholdSetting::Fixed(t),
                Threshold::Otsu => ThresholdSetting::Named(ThresholdName::Otsu),
            },
            polarity: PolaritySetting::from_core(p.polarity),
            cleanup: match p.cleanup {
                Cleanup::Off => CleanupSetting::Off,
                Cleanup::Open => CleanupSetting::Open,
                Cleanup::OpenClose => CleanupSetting::OpenClose,
            },
            min_points: p.min_points,
            min_area: p.min_area,
            n: p.n,
            m: p.m,
            k: p.k,
            omega: p.omega,
            epsilon: p.epsilon,
            angle: match p.angle {
                AngleEstimator::Signed => AngleSetting::Signed,
                AngleEstimator::Paper => AngleSetting::Paper,
            },
            refine: match p.refine {
                Refine::Off => RefineSetting::Off,
                Refine::Pose => RefineSetting::Pose,
                Refine::Verify => RefineSetting::Verify,
            },
            candidates: p.candidates,
            candidate_ratio: p.candidate_ratio,
            verify_threshold: p.verify_threshold,
            verify_relative: p.verify_relative,
            offset_relative: p.offset_relative,
            scale_min: p.scale_min,
            scale_max: p.scale_max,
            position: match p.position {
                Position::Polygon => PositionSetting::Polygon,
                Position::PartialVolume => PositionSetting::PartialVolume,
                Position::Pose => PositionSetting::Pose,
            },
            exposure: ExposureSetting::Fit,
            platform_every: DEFAULT_PLATFORM_EVERY,
            nested_parts: p.nested_parts,
            flipped_parts: p.flipped_parts,
            touching_parts: p.touching_parts,
        }
    }

    /// The core parameters, checked.
    ///
    /// # Errors
    /// The core's validation message.
    pub fn to_params(&self) -> Result<Params, String> {
        if self.platform_every == 0 {
            return Err("invalid parameters: platform_every must be at least 1 (1: every frame is estimated)".into());
        }
        let p = Params {
            alpha: self.alpha,
            threshold: match self.threshold {
                ThresholdSetting::Fixed(t) => Threshold::Fixed(t),
                ThresholdSetting::Named(ThresholdName::Otsu) => Threshold::Otsu,
            },
            polarity: self.polarity.to_core(),
            cleanup: match self.cleanup {
                CleanupSetting::Off => Cleanup::Off,
                CleanupSetting::Open => Cleanup::Open,
                CleanupSetting::OpenClose => Cleanup::OpenClose,
            },
            min_points: self.min_points,
            min_area: self.min_area,
            n: self.n,
            m: self.m,
            k: self.k,
            omega: self.omega,
            epsilon: self.epsilon,
            angle: match self.angle {
                AngleSetting::Signed => AngleEstimator::Signed,
                AngleSetting::Paper => AngleEstimator::Paper,
            },
            refine: match self.refine {
                RefineSetting::Off => Refine::Off,
                RefineSetting::Pose => Refine::Pose,
                RefineSetting::Verify => Refine::Verify,
            },
            candidates: self.candidates,
            candidate_ratio: self.candidate_ratio,
            verify_threshold: self.verify_threshold,
            verify_relative: self.verify_relative,
            offset_relative: self.offset_relative,
            scale_min: self.scale_min,
            scale_max: self.scale_max,
            position: match self.position {
                PositionSetting::Polygon => Position::Polygon,
                PositionSetting::PartialVolume => Position::PartialVolume,
                PositionSetting::Pose => Position::Pose,
            },
            nested_parts: self.nested_parts,
            flipped_parts: self.flipped_parts,
            touching_parts: self.touching_parts,
        };
        p.validate().map_err(|e| format!("invalid parameters: {e}"))?;
        Ok(p)
    }

    /// Reads a TOML config file.
    ///
    /// # Errors
    /// A one-line message naming the file.
    pub fn load(path: &std::path::Path) -> Result<Self, String> {
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("{}: {}", path.display(), crate::io::io_problem(&e)))?;
        toml::from_str(&text).map_err(|e| format!("{}: not a valid vorl config: {}", path.display(), e.message()))
    }

    /// This config with the keys of another file on top (a set's `vorl.toml` under `--config`).
    ///
    /// # Errors
    /// The file cannot be read, or holds an unknown key or a bad value.
    pub fn overlay(&self, path: &std::path::Path) -> Result<Self, String> {
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("{}: {}", path.display(), crate::io::io_problem(&e)))?;
        let top: toml::Table = toml::from_str(&text)
            .map_err(|e| format!("{}: not a valid vorl config: {}", path.display(), e.message()))?;
        let mut base = toml::Table::try_from(self).map_err(|e| e.to_string())?;
        for (k, v) in top {
            base.insert(k, v);
        }
        base.try_into()
            .map_err(|e: toml::de::Error| format!("{}: not a valid vorl config: {}", path.display(), e.message()))
    }

    /// Every parameter with its default and meaning, as a commented TOML file.
    pub fn defaults_toml() -> String {
        let d = Config::default();
        let thr = match d.threshold {
            ThresholdSetting::Fixed(t) => t.to_string(),
            ThresholdSetting::Named(_) => "\"otsu\"".into(),
        };
        let angle = match d.angle {
            AngleSetting::Signed => "signed",
            AngleSetting::Paper => "paper",
        };
        format!(
            "# vorl pipeline parameters (defaults). Pass with --config FILE; flags override.\n\
             # Weight of intensity against gradient in I' = α·I + (1−α)·|∇I| (paper eq. 3.1), 0..1.\n\
             alpha = {:?}\n\
             # Foreground threshold on |I' − B|: 0..255, or \"otsu\" for Otsu's level per frame.\n\
             threshold = {}\n\
             # Which parts are foreground: \"either\" (darker or brighter than the platform), \"darker\", or \"brighter\"\n\
             # (front-lit parts on a darker mat: the shadow beside a part is then not part of it). `vorl teach` measures it.\n\
             polarity = \"{}\"\n\
             # 3×3 clean-up of the mask: \"off\", \"open\" (removes specks; keeps narrow holes), \"open-close\" (also fills pinholes and holes under ~3 px).\n\
             cleanup = \"{}\"\n\
             # Fewest border points of a kept contour.\n\
             min_points = {}\n\
             # Smallest area of a kept contour, px².\n\
             min_area = {:?}\n\
             # Points a part contour is resampled to (n).\n\
             n = {}\n\
             # Points a template contour is resampled to (m; n ≤ m < 2n, eq. 4.5).\n\
             m = {}\n\
             # Neighbourhood k of the descriptor's angle term (eq. 4.2), in part points; templates use round(k·m/n).\n\
             k = {}\n\
             # Weight ω of the angle term in c = ω·a + (1−ω)·d (eq. 4.3), 0..1.\n\
             omega = {:?}\n\
             # Decision threshold ε: a part is known iff f' = f_min/n < ε (eqs. 5.1–5.2).\n\
             epsilon = {:?}\n\
             # Rotation estimator when the pose is not refined: \"signed\" (least squares, 0–360°) or \"paper\" (eq. 6.4, unsigned 0–180°).\n\
             angle = \"{}\"\n\
             # After the DP: \"off\" (the paper's path: best f', f' < ε), \"pose\" (the paper's decision, pose aligned on the frame),\n\
             # \"verify\" (the best candidates aligned and verified; lowest score wins, unknown at or above verify_threshold).\n\
             refine = \"{}\"\n\
             # Candidates aligned and verified per part with refine = \"verify\" (1..8).\n\
             candidates = {}\n\
             # Templates are searched in ascending order of their sorted-value bound; one is a candidate only if its DP cost is below\n\
             # this multiple of the lowest cost before it (≥ 1; 1: each candidate beats every earlier one; inf: the first `candidates`).\n\
             candidate_ratio = {}\n\
             # Verification threshold, px (mean distance between the aligned outlines, both ways): unknown at or above the larger\n\
             # of verify_threshold and verify_relative × the part's size (√(area/π) of its template times the aligned scale).\n\
             verify_threshold = {:?}\n\
             verify_relative = {:?}\n\
             # Largest uniform offset of the outline (along its normals) the alignment fits, relative to the part's size.\n\
             offset_relative = {:?}\n\
             # Accepted range of part size over template size (camera height, lens, part-to-part variation).\n\
             scale_min = {:?}\n\
             scale_max = {:?}\n\
             # Position: \"polygon\" (the paper's border centroid), \"partial-volume\" (edge pixels by coverage), \"pose\" (template centroid through the aligned pose).\n\
             position = \"{}\"\n\
             # With an empty shot: \"fit\" each frame's gain and offset against it on the platform's pixels and undo them\n\
             # (a brighter or dimmer exposure gives the same masks), or \"fixed\". Without one the platform is estimated from the frames.\n\
             exposure = \"{}\"\n\
             # Without an empty shot: most frames one platform estimate serves (its own included) while they still fit it\n\
             # (the same exposure, no larger spread of the platform's residuals); 1: every frame is estimated anew.\n\
             platform_every = {}\n\
             # Whether an outer border inside a hole of another part (print, a label, a small part resting in a ring) is a part\n\
             # of its own; false: it is reported as a skip (\"inside a hole of another part\"), not as a part.\n\
             nested_parts = {}\n\
             # Whether parts may lie upside down: every chiral template's mirror image (`vorl templates info` says which are\n\
             # chiral) is matched too, and a part that fits it is reported \"flipped\": true; false for a feeder that never flips parts.\n\
             flipped_parts = {}\n\
             # Whether a blob whose border is not one template's is searched for the parts along it (touching and overlapping\n\
             # parts, parts the frame's edge cuts that show half their border), reported \"touching\": true with \"visible_fraction\";\n\
             # a blob inside the frame whose border turns concave nowhere by 54 degrees (no junction of two outlines) is one part.\n\
             touching_parts = {}\n",
            d.alpha, thr, setting_name(&d.polarity), setting_name(&d.cleanup), d.min_points, d.min_area, d.n, d.m, d.k, d.omega, d.epsilon, angle,
            setting_name(&d.refine), d.candidates, toml_float(d.candidate_ratio), d.verify_threshold,
            d.verify_relative, d.offset_relative, d.scale_min, d.scale_max, setting_name(&d.position),
            setting_name(&d.exposure), d.platform_every, d.nested_parts, d.flipped_parts,
            d.touching_parts
        )
    }
}

/// A float as TOML writes it (`inf` for infinity).
fn toml_float(v: f32) -> String {
    if v.is_infinite() {
        if v > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        }
    } else {
        format!("{v:?}")
    }
}

/// The kebab-case name of a setting, as serde writes it.
fn setting_name<T: Serialize>(v: &T) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_toml_round_trips() {
        let c: Config = toml::from_str(&Config::defaults_toml()).unwrap();
        assert_eq!(c, Config::default());
        assert_eq!(c.to_params().unwrap(), Params::DEFAULT);
    }

    #[test]
    fn otsu_and_unknown_keys() {
        let c: Config = toml::from_str("threshold = \"otsu\"").unwrap();
        assert_eq!(c.to_params().unwrap().threshold, Threshold::Otsu);
        assert!(toml::from_str::<Config>("thresold = 3").is_err());
    }
}
