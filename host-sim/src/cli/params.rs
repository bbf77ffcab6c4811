//! Parameter flags shared by the subcommands that run the pipeline.

use std::path::PathBuf;

use vorl_core::Params;

use crate::config::{
    AngleSetting, CleanupSetting, Config, ExposureSetting, PolaritySetting, PositionSetting, RefineSetting,
    ThresholdName, ThresholdSetting,
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
    /// Which parts are foreground: darker or brighter than the platform, or either (`vorl
    /// teach` measures it: a shadow beside a brighter part is not part of it).
    #[arg(long, value_enum)]
    pub polarity: Option<PolaritySetting>,
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
            cleanup,
            polarity,
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

#[cfg(test)]
mod tests {
    use clap::{Args, CommandFactory, Parser};

    use super::*;

    /// A command of nothing but the pipeline flags.
    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        params: ParamArgs,
    }

    /// Whether a config holds the value a row's flag gives.
    type Holds = fn(&Config) -> bool;

    /// Every flag of [`ParamArgs`] (long name without `--`), a value other than the default, and
    /// whether a config holds it. `--config`'s value is a file setting `min_points`, which no
    /// flag sets.
    const FLAGS: &[(&str, &str, Holds)] = &[
        ("config", "", |c| c.min_points == 7),
        ("threshold", "42", |c| c.threshold == ThresholdSetting::Fixed(42)),
        ("cleanup", "open-close", |c| c.cleanup == CleanupSetting::OpenClose),
        ("polarity", "brighter", |c| c.polarity == PolaritySetting::Brighter),
        ("alpha", "0.75", |c| c.alpha == 0.75),
        ("n", "48", |c| c.n == 48),
        ("m", "80", |c| c.m == 80),
        ("k", "6", |c| c.k == 6),
        ("omega", "0.25", |c| c.omega == 0.25),
        ("epsilon", "0.125", |c| c.epsilon == 0.125),
        ("angle", "paper", |c| c.angle == AngleSetting::Paper),
        ("refine", "pose", |c| c.refine == RefineSetting::Pose),
        ("candidates", "5", |c| c.candidates == 5),
        ("candidate-ratio", "2.5", |c| c.candidate_ratio == 2.5),
        ("verify-threshold", "1.5", |c| c.verify_threshold == 1.5),
        ("verify-relative", "0.0625", |c| c.verify_relative == 0.0625),
        ("offset-relative", "0.125", |c| c.offset_relative == 0.125),
        ("scale-min", "0.75", |c| c.scale_min == 0.75),
        ("scale-max", "1.5", |c| c.scale_max == 1.5),
        ("position", "polygon", |c| c.position == PositionSetting::Polygon),
        ("exposure", "fixed", |c| c.exposure == ExposureSetting::Fixed),
        ("platform-every", "3", |c| c.platform_every == 3),
        ("nested-parts", "true", |c| c.nested_parts),
        ("flipped-parts", "false", |c| !c.flipped_parts),
        ("touching-parts", "false", |c| !c.touching_parts),
    ];

    /// Every flag of [`ParamArgs`] has a row in [`FLAGS`], and each flag, given a value other
    /// than the default, reaches the [`Config`]: a flag added without being applied, or without
    /// a row here, fails.
    #[test]
    fn every_flag_reaches_the_config() {
        let declared: Vec<String> = ParamArgs::augment_args(clap::Command::new("params"))
            .get_arguments()
            .map(|a| a.get_long().map_or_else(|| a.get_id().to_string(), str::to_string))
            .collect();
        for flag in &declared {
            assert!(
                FLAGS.iter().any(|(f, _, _)| f == flag),
                "--{flag} has no row in FLAGS: add one, and apply it in config_over"
            );
        }
        for (flag, _, _) in FLAGS {
            assert!(
                declared.iter().any(|d| d == flag),
                "FLAGS names --{flag}, which ParamArgs lacks"
            );
        }
        Cli::command().debug_assert();

        let file = std::env::temp_dir().join(format!("vorl-params-test-{}.toml", std::process::id()));
        std::fs::write(&file, "min_points = 7\n").expect("write the config file");
        let mut line = vec!["params".to_string()];
        for (flag, value, _) in FLAGS {
            line.push(format!("--{flag}"));
            line.push(if *flag == "config" {
                file.display().to_string()
            } else {
                value.to_string()
            });
        }
        let parsed = Cli::try_parse_from(&line).map(|cli| cli.params.config());
        std::fs::remove_file(&file).ok();
        let config = parsed.expect("the command line parses").expect("the config loads");
        let defaults = Config::default();
        for (flag, value, holds) in FLAGS {
            assert!(!holds(&defaults), "--{flag} {value} is the default: pick another value");
            assert!(holds(&config), "--{flag} {value} did not reach the config: {config:?}");
        }
    }
}
