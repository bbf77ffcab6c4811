//! Parameter flags shared by the subcommands that run the pipeline.

use std::path::PathBuf;

use vorl_core::Params;

use crate::config::{
    AngleSetting, CleanupSetting, Config, ExposureSetting, PositionSetting, RefineSetting, ThresholdName,
    ThresholdSetting,
};

/// Pipeline parameters: a config file, then single flags on top.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ParamArgs {
    /// TOML file of parameters (see `vorl config --defaults`).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Foreground threshold τ on |I' − B| (0..255) or "otsu".
    #[arg(long, value_name = "TAU|otsu")]
    pub threshold: Option<String>,
    /// 3×3 clean-up of the mask.
    #[arg(long, value_enum)]
    pub cleanup: Option<CleanupSetting>,
    /// Intensity weight α of I' = α·I + (1−α)·|∇I|.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// Points per part contour (n).
    #[arg(long)]
    pub n: Option<usize>,
    /// Points per template contour (m, n ≤ m < 2n).
    #[arg(long)]
    pub m: Option<usize>,
    /// Descriptor neighbourhood k.
    #[arg(long)]
    pub k: Option<usize>,
    /// Descriptor angle weight ω.
    #[arg(long)]
    pub omega: Option<f32>,
    /// Decision threshold ε on f'.
    #[arg(long)]
    pub epsilon: Option<f32>,
    /// Rotation estimator when the pose is not refined.
    #[arg(long, value_enum)]
    pub angle: Option<AngleSetting>,
    /// After the DP: off (the paper's path), pose, verify.
    #[arg(long, value_enum)]
    pub refine: Option<RefineSetting>,
    /// Candidates aligned and verified per part (with --refine verify).
    #[arg(long)]
    pub candidates: Option<usize>,
    /// A template is a candidate only if its DP cost is below this multiple of the lowest cost
    /// of the templates before it in the sorted-bound order (≥ 1; "inf": no limit).
    #[arg(long)]
    pub candidate_ratio: Option<f32>,
    /// Verification threshold, px.
    #[arg(long)]
    pub verify_threshold: Option<f32>,
    /// Verification threshold relative to the part's size (√(area/π) × scale).
    #[arg(long)]
    pub verify_relative: Option<f32>,
    /// Largest outline offset the alignment fits, relative to the part's size.
    #[arg(long)]
    pub offset_relative: Option<f32>,
    /// Smallest accepted part size over template size.
    #[arg(long)]
    pub scale_min: Option<f32>,
    /// Largest accepted part size over template size.
    #[arg(long)]
    pub scale_max: Option<f32>,
    /// Position estimator.
    #[arg(long, value_enum)]
    pub position: Option<PositionSetting>,
    /// With an empty shot: fit each frame's gain and offset against it (default), or fixed.
    #[arg(long, value_enum)]
    pub exposure: Option<ExposureSetting>,
    /// Without an empty shot: most frames one platform estimate serves while they fit it (1:
    /// every frame estimated).
    #[arg(long, value_name = "N")]
    pub platform_every: Option<u32>,
    /// Report outer borders inside a hole of another part (print, a nested part) as parts.
    #[arg(long, value_name = "true|false")]
    pub nested_parts: Option<bool>,
    /// Match chiral templates' mirror images too, reporting parts upside down as flipped
    /// (default true; false for a feeder that never flips parts).
    #[arg(long, value_name = "true|false")]
    pub flipped_parts: Option<bool>,
    /// Search blobs whose border is not one template's for the parts along it: touching and
    /// overlapping parts, parts cut by the frame's edge (default false).
    #[arg(long, value_name = "true|false")]
    pub touching_parts: Option<bool>,
}

impl ParamArgs {
    /// The config file (or defaults) with the flags applied.
    ///
    /// # Errors
    /// The config file cannot be read, a flag is malformed, or a value is out of range.
    pub fn config(&self) -> Result<Config, String> {
        self.config_over(None)
    }

    /// [`Self::config`] over a set's own `vorl.toml` (`base`): the defaults, then `base`, then
    /// `--config`'s file, then the flags.
    ///
    /// # Errors
    /// As [`Self::config`]; a `base` that cannot be read or holds an unknown key or bad value.
    pub fn config_over(&self, base: Option<&std::path::Path>) -> Result<Config, String> {
        let mut c = match (&self.config, base) {
            (Some(p), Some(b)) => Config::load(b)?.overlay(p)?,
            (Some(p), None) => Config::load(p)?,
            (None, Some(b)) => Config::load(b)?,
            (None, None) => Config::default(),
        };
        if let Some(t) = &self.threshold {
            c.threshold = if t.eq_ignore_ascii_case("otsu") {
                ThresholdSetting::Named(ThresholdName::Otsu)
            } else {
                ThresholdSetting::Fixed(
                    t.parse()
                        .map_err(|_| format!("--threshold {t}: expected 0..255 or \"otsu\""))?,
                )
            };
        }
        macro_rules! set {
            ($($f:ident),*) => { $( if let Some(v) = self.$f { c.$f = v; } )* };
        }
        set!(
            alpha,
            n,
            m,
            k,
            omega,
            epsilon,
            angle,
            refine,
            candidates,
            candidate_ratio,
            verify_threshold,
            verify_relative,
            offset_relative,
            scale_min,
            scale_max,
            position,
            exposure,
            platform_every,
            nested_parts,
            flipped_parts,
            touching_parts
        );
        Ok(c)
    }

    /// The checked core parameters.
    ///
    /// # Errors
    /// As [`Self::config`] and [`Config::to_params`].
    pub fn params(&self) -> Result<Params, String> {
        self.config()?.to_params()
    }

    /// [`Self::params`] over a set's `vorl.toml`.
    ///
    /// # Errors
    /// As [`Self::config_over`] and [`Config::to_params`].
    pub fn params_over(&self, base: Option<&std::path::Path>) -> Result<Params, String> {
        self.config_over(base)?.to_params()
    }
}
