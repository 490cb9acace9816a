//! What the analyst has chosen: fusion weights, median filter, threshold, the reference
//! of the metrics, which view and overlays are shown, heatmap opacity. Plain data, saved
//! with the layout between runs.

use serde::{Deserialize, Serialize};

use crate::render::{Colormap, FrameView};
use crate::score::FusionWeights;

/// The main view's modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ViewMode {
    /// The frame with overlays.
    #[default]
    Frame,
    /// The actual frame beside the frame with predicted patches.
    Prediction,
    /// The flow beside its reconstruction.
    Flow,
}

impl ViewMode {
    /// Every mode, in key order (1, 2, 3).
    pub const ALL: [Self; 3] = [Self::Frame, Self::Prediction, Self::Flow];

    /// A name for buttons and captions.
    pub fn name(self) -> &'static str {
        match self {
            Self::Frame => "frame",
            Self::Prediction => "predicted vs actual",
            Self::Flow => "flow vs reconstruction",
        }
    }

    /// The per-frame view the mode shows.
    pub fn frame_view(self) -> FrameView {
        match self {
            Self::Frame => FrameView::Frame,
            Self::Prediction => FrameView::Pred,
            Self::Flow => FrameView::Flow,
        }
    }
}

/// The overlays of the frame view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Overlay {
    /// The pixel anomaly heatmap.
    Heatmap,
    /// The object boxes with their scores.
    Boxes,
    /// The ground-truth anomaly mask as a contour.
    Mask,
    /// The caption strip.
    Caption,
}

impl Overlay {
    /// Every overlay.
    pub const ALL: [Self; 4] = [Self::Heatmap, Self::Boxes, Self::Mask, Self::Caption];

    /// A name for buttons.
    pub fn name(self) -> &'static str {
        match self {
            Self::Heatmap => "heatmap",
            Self::Boxes => "boxes",
            Self::Mask => "anomaly mask",
            Self::Caption => "caption",
        }
    }
}

/// Which overlays are on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Overlays {
    /// The pixel heatmap.
    pub heatmap: bool,
    /// Boxes.
    pub boxes: bool,
    /// Anomaly-mask contour.
    pub mask: bool,
    /// Caption strip.
    pub caption: bool,
}

impl Default for Overlays {
    fn default() -> Self {
        Self {
            heatmap: true,
            boxes: true,
            mask: true,
            caption: true,
        }
    }
}

impl Overlays {
    /// Whether `overlay` is on.
    pub fn is_on(&self, overlay: Overlay) -> bool {
        match overlay {
            Overlay::Heatmap => self.heatmap,
            Overlay::Boxes => self.boxes,
            Overlay::Mask => self.mask,
            Overlay::Caption => self.caption,
        }
    }

    /// Turns `overlay` on or off.
    pub fn toggle(&mut self, overlay: Overlay) {
        let flag = match overlay {
            Overlay::Heatmap => &mut self.heatmap,
            Overlay::Boxes => &mut self.boxes,
            Overlay::Mask => &mut self.mask,
            Overlay::Caption => &mut self.caption,
        };
        *flag = !*flag;
    }
}

/// Where the decision threshold comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ThresholdMode {
    /// render's reference threshold for the weights (3 training σ in both errors); needs no
    /// labels, and is what `vadscope render` and `export` use.
    #[default]
    Reference,
    /// The data set's F1-max threshold (optimistic: chosen with the labels).
    F1Max,
    /// The analyst's value.
    Manual,
}

impl ThresholdMode {
    /// Every mode, in the panel's order.
    pub const ALL: [Self; 3] = [Self::Reference, Self::F1Max, Self::Manual];

    /// A name for the panel.
    pub fn name(self) -> &'static str {
        match self {
            Self::Reference => "reference (3σ)",
            Self::F1Max => "F1-max",
            Self::Manual => "manual",
        }
    }
}

/// The per-frame anomaly flags the metrics, failure cases and events are measured against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reference {
    /// The scenario's ground truth (`frame_labels.csv` and the like).
    #[default]
    GroundTruth,
    /// The analyst's anomaly intervals (labeling mode; ground truth where a scenario's
    /// labels cannot be opened).
    AnalystLabels,
}

impl Reference {
    /// Both, in the panel's order.
    pub const ALL: [Self; 2] = [Self::GroundTruth, Self::AnalystLabels];

    /// A name for the panel.
    pub fn name(self) -> &'static str {
        match self {
            Self::GroundTruth => "ground truth",
            Self::AnalystLabels => "analyst labels",
        }
    }
}

/// Detections more than this many frames after the onset count as late (0.5 s at 10 Hz).
pub const DEFAULT_LATE_AFTER: usize = 5;

/// The analyst's choices.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewSettings {
    /// Fusion weights.
    pub weights: FusionWeights,
    /// Median-filter kernel of the frame scores (odd; 0 or 1 = none; the reference's 17).
    pub median_kernel: usize,
    /// Where the decision threshold on the filtered score comes from.
    pub threshold_mode: ThresholdMode,
    /// The analyst's threshold (used in [`ThresholdMode::Manual`]).
    pub manual_threshold: f64,
    /// Frames after an onset beyond which a detection is late.
    pub late_after: usize,
    /// What the metrics are measured against.
    pub reference: Reference,
    /// What the main view shows.
    pub view: ViewMode,
    /// Overlays of the frame view.
    pub overlays: Overlays,
    /// Heatmap opacity, 0–1.
    pub opacity: f32,
    /// Colormap of heatmaps, error maps and boxes.
    #[serde(with = "colormap_name")]
    pub colormap: Colormap,
}

impl Default for ViewSettings {
    fn default() -> Self {
        Self {
            weights: FusionWeights::default(),
            median_kernel: 17,
            threshold_mode: ThresholdMode::default(),
            manual_threshold: 0.0,
            late_after: DEFAULT_LATE_AFTER,
            reference: Reference::default(),
            view: ViewMode::default(),
            overlays: Overlays::default(),
            opacity: 0.6,
            colormap: Colormap::default(),
        }
    }
}

/// Colormaps are stored by name.
mod colormap_name {
    use serde::{Deserialize, Deserializer, Serializer};

    use crate::render::Colormap;

    pub fn serialize<S: Serializer>(colormap: &Colormap, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(colormap.name())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Colormap, D::Error> {
        let name = String::deserialize(deserializer)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}
