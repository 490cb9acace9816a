//! What `vadscope render` and `vadscope export` share: the options that say which scenario
//! and frames to draw, how (colormap, heatmap range, size), with which scores and where to
//! write ([`ScenarioViewArgs`]), and what both do with them (open the scenario with a
//! current score cache, clip the frame range, write a PNG).

use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use image::RgbaImage;
use vadscope::export;
use vadscope::render::{Colormap, DrawSettings};
use vadscope::score::FusionParams;
use vadscope::score::ScoreCache;
use vadscope::sequence::Scenario;
use vadscope::synth::parse_size;

use super::score_cache::{ScoreArgs, current_cache};

/// Options of a command that draws views of a scenario's frames into a folder.
#[derive(Debug, Args)]
pub struct ScenarioViewArgs {
    /// The scenario folder.
    pub scenario: PathBuf,
    /// Folder to write into (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frames to draw, as START..END (END excluded) or one index (default: all).
    #[arg(long, value_name = "START..END", value_parser = parse_frames)]
    pub frames: Option<Range<usize>>,
    /// Colormap of heatmaps, error maps and boxes: turbo, viridis, inferno or jet.
    #[arg(long, default_value = "turbo")]
    pub colormap: Colormap,
    /// Scale the heatmap per frame (labelled) instead of the model's reference range.
    #[arg(long)]
    pub auto_range: bool,
    /// Image size as WIDTHxHEIGHT (default: per view; frame views show the frame 1:1 with
    /// caption and colour bar).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    #[command(flatten)]
    pub scores: ScoreArgs,
}

impl ScenarioViewArgs {
    /// Opens the scenario and its current score cache (scoring first when needed); also
    /// returns the checkpoint the scores come from.
    pub fn open_scored(&self) -> anyhow::Result<(Scenario, ScoreCache, PathBuf)> {
        let scenario = Scenario::open(&self.scenario)
            .with_context(|| format!("cannot open scenario {}", self.scenario.display()))?;
        let (cache, model) = current_cache(&scenario, &self.scores)?;
        Ok((scenario, cache, model))
    }

    /// The asked frames clipped to `scenario`, with an error when nothing is left.
    pub fn frames_in(&self, scenario: &Scenario) -> anyhow::Result<Range<usize>> {
        Ok(export::frames_in(scenario, self.frames.as_ref())?)
    }

    /// The draw settings these options choose.
    pub fn settings(&self) -> DrawSettings {
        DrawSettings {
            fusion: FusionParams {
                weights: self.scores.fusion_weights(),
                median_kernel: self.scores.median_kernel,
            },
            threshold: self.scores.decision_threshold(),
            colormap: self.colormap,
            auto_range: self.auto_range,
        }
    }

    /// Creates the output folder `sub` below `--out` (`""` for `--out` itself).
    pub fn create_out(&self, sub: &str) -> anyhow::Result<PathBuf> {
        let dir = self.out.join(sub);
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        Ok(dir)
    }
}

/// Parses `A..B` (B excluded) or a single frame index `A`.
fn parse_frames(text: &str) -> Result<Range<usize>, String> {
    let bad =
        |e: std::num::ParseIntError| format!("{text:?}: {e} (expected START..END or one index)");
    match text.split_once("..") {
        Some((a, b)) => {
            let (a, b) = (
                a.trim().parse::<usize>().map_err(bad)?,
                b.trim().parse::<usize>().map_err(bad)?,
            );
            if b <= a {
                return Err(format!("{text:?}: END must be greater than START"));
            }
            Ok(a..b)
        }
        None => {
            let a = text.trim().parse::<usize>().map_err(bad)?;
            Ok(a..a + 1)
        }
    }
}

/// Writes `image` as PNG at `path`.
pub fn save_png(image: &RgbaImage, path: &Path) -> anyhow::Result<()> {
    Ok(export::write_png(image, path)?)
}
