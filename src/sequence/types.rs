//! Plain data types shared by the readers, the writer and the generator.

use serde::{Deserialize, Serialize};

/// An AnoVox frame id: the integer after the last `_` of a file stem. In released AnoVox
/// data it is the global CARLA world tick (consecutive, not 0-based); data we generate
/// uses 0-based ids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct FrameId(pub u64);

impl std::fmt::Display for FrameId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The per-frame data types of a scenario, named as AnoVox's benchmark layout names its
/// folders (plus vadscope's `OPTICAL_FLOW` extension).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Modality {
    /// `RGB_IMG`: the camera frame, 8-bit RGB.
    Rgb,
    /// `SEMANTIC_IMG`: class ids (L) or palette colours (RGB).
    Semantic,
    /// `INSTANCE_IMG`: R = class tag, G + 256·B = instance id.
    Instance,
    /// `DEPTH_IMG`: CARLA raw 24-bit depth.
    Depth,
    /// `OPTICAL_FLOW`: flow from the previous frame to this one.
    Flow,
    /// `ACTION`: ego state, `key ; value` lines.
    Action,
    /// `ANOMALY`: anomaly actor state (the lead vehicle for sudden braking).
    Anomaly,
}

impl Modality {
    /// Every modality, in folder order.
    pub const ALL: [Modality; 7] = [
        Modality::Rgb,
        Modality::Semantic,
        Modality::Instance,
        Modality::Depth,
        Modality::Flow,
        Modality::Action,
        Modality::Anomaly,
    ];

    /// The benchmark-layout folder name (also the file-name prefix).
    pub fn folder(self) -> &'static str {
        match self {
            Modality::Rgb => "RGB_IMG",
            Modality::Semantic => "SEMANTIC_IMG",
            Modality::Instance => "INSTANCE_IMG",
            Modality::Depth => "DEPTH_IMG",
            Modality::Flow => "OPTICAL_FLOW",
            Modality::Action => "ACTION",
            Modality::Anomaly => "ANOMALY",
        }
    }
}

/// One 2D box of one frame: a row of `BBOX_2D/boxes.csv`
/// (`frame,track_id,x1,y1,x2,y2,class,score,anomalous`; pixels, x2/y2 exclusive).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoxRecord {
    /// AnoVox frame id the box belongs to.
    pub frame: FrameId,
    /// Track id, stable over the frames of one object.
    pub track_id: u64,
    /// Left edge (inclusive), pixels.
    pub x1: f32,
    /// Top edge (inclusive), pixels.
    pub y1: f32,
    /// Right edge (exclusive), pixels.
    pub x2: f32,
    /// Bottom edge (exclusive), pixels.
    pub y2: f32,
    /// AnoVox / CARLA class id (14 car, 15 truck, 16 bus, ...).
    pub class: u16,
    /// Confidence; 1 for ground truth.
    pub score: f32,
    /// Whether the object is the anomaly in this frame.
    pub anomalous: bool,
}

impl BoxRecord {
    /// A ground-truth car box (class 14, score 1, not anomalous) of `frame` and `track_id`
    /// with corners `[x1, y1, x2, y2]`; other fields can be set on the result.
    pub fn car(frame: FrameId, track_id: u64, [x1, y1, x2, y2]: [f32; 4]) -> Self {
        Self {
            frame,
            track_id,
            x1,
            y1,
            x2,
            y2,
            class: 14,
            score: 1.0,
            anomalous: false,
        }
    }

    /// Box width in pixels.
    pub fn width(&self) -> f32 {
        self.x2 - self.x1
    }

    /// Box height in pixels.
    pub fn height(&self) -> f32 {
        self.y2 - self.y1
    }
}

/// Road environment of a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Domain {
    /// Urban streets: buildings, crossings, traffic lights, parked cars.
    City,
    /// Multi-lane highway with guardrails and vegetation.
    Highway,
    /// Not known (e.g. real data without metadata).
    Unknown,
}

/// Weather / lighting condition of a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Weather {
    /// Clear daylight.
    Sun,
    /// Rain: darker, lower contrast, streaks, wet road.
    Rain,
    /// Fog: contrast falls off with distance.
    Fog,
    /// Night: headlights and lit tail lights.
    Night,
    /// Not known.
    Unknown,
}

/// What kind of event a scenario contains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum AnomalyType {
    /// Normal driving only (AnoVox `NORMALITY`).
    Normality,
    /// The lead vehicle brakes hard to a standstill (AnoVox spells it "BREAKING").
    #[serde(rename = "SUDDEN_BREAKING_OF_VEHICLE_AHEAD")]
    SuddenBraking,
    /// A static anomaly object on the road (AnoVox `STATIC`).
    Static,
    /// Hard normal case: the lead vehicle turns off the road.
    LeadTurning,
    /// Hard normal case: a vehicle cuts into the ego lane.
    CutIn,
}

/// Pinhole camera intrinsics and mounting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraIntrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Horizontal field of view in degrees.
    pub fov_deg: f32,
    /// Focal length in pixels (x).
    pub fx: f32,
    /// Focal length in pixels (y).
    pub fy: f32,
    /// Principal point x.
    pub cx: f32,
    /// Principal point y.
    pub cy: f32,
    /// Mounting height above the road in metres.
    pub mount_height_m: f32,
}

impl CameraIntrinsics {
    /// AnoVox's camera: FOV 90°, principal point at the image centre, mounted at 1.8 m.
    pub fn anovox(width: u32, height: u32) -> Self {
        Self::from_fov(width, height, 90.0, 1.8)
    }

    /// A camera of `width`×`height` pixels with a horizontal field of view of `fov_deg`
    /// degrees, square pixels, the principal point at the image centre (CARLA's camera),
    /// mounted `mount_height_m` above the road.
    pub fn from_fov(width: u32, height: u32, fov_deg: f32, mount_height_m: f32) -> Self {
        let f = width as f32 / (2.0 * (fov_deg.to_radians() / 2.0).tan());
        Self {
            width,
            height,
            fov_deg,
            fx: f,
            fy: f,
            cx: width as f32 / 2.0,
            cy: height as f32 / 2.0,
            mount_height_m,
        }
    }
}

/// An inclusive range of frame ids during which the anomaly is present.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameWindow {
    /// First anomalous frame id.
    pub start: FrameId,
    /// Last anomalous frame id (inclusive).
    pub end: FrameId,
}

/// `scenario.json`: vadscope's per-scenario metadata (all fields optional when reading).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioMeta {
    /// City or highway.
    #[serde(default = "unknown_domain")]
    pub domain: Domain,
    /// Weather / lighting.
    #[serde(default = "unknown_weather")]
    pub weather: Weather,
    /// Free text, e.g. "day", "dusk", "night".
    #[serde(default)]
    pub time_of_day: Option<String>,
    /// What happens in the scenario.
    #[serde(default)]
    pub anomaly_type: Option<AnomalyType>,
    /// The anomaly window in frame ids, when there is one.
    #[serde(default)]
    pub anomaly_window: Option<FrameWindow>,
    /// Town or map name (AnoVox `map`).
    #[serde(default)]
    pub town: Option<String>,
    /// Generator seed, for generated data.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Generator name and version, for generated data.
    #[serde(default)]
    pub generator: Option<String>,
    /// Frames per second (AnoVox records at 10 Hz).
    #[serde(default = "default_fps")]
    pub fps: f32,
    /// Camera intrinsics, when known.
    #[serde(default)]
    pub camera: Option<CameraIntrinsics>,
}

fn unknown_domain() -> Domain {
    Domain::Unknown
}

fn unknown_weather() -> Weather {
    Weather::Unknown
}

fn default_fps() -> f32 {
    10.0
}

impl Default for ScenarioMeta {
    fn default() -> Self {
        Self {
            domain: Domain::Unknown,
            weather: Weather::Unknown,
            time_of_day: None,
            anomaly_type: None,
            anomaly_window: None,
            town: None,
            seed: None,
            generator: None,
            fps: default_fps(),
            camera: None,
        }
    }
}

/// An ACTION or ANOMALY file: ordered `key ; value` pairs (values are Python reprs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KeyValues {
    /// The pairs in file order, keys and values trimmed.
    pub entries: Vec<(String, String)>,
}

impl KeyValues {
    /// The raw value of `key`, if present.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.entries
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The value of `key` parsed as a number (Python `True`/`False` read as 1/0).
    pub fn get_f64(&self, key: &str) -> Option<f64> {
        match self.get(key)? {
            "True" => Some(1.0),
            "False" => Some(0.0),
            v => v.parse().ok(),
        }
    }

    /// Speed in km/h (AnoVox `speed`).
    pub fn speed_kmh(&self) -> Option<f64> {
        self.get_f64("speed")
    }

    /// Brake command in [0, 1] (AnoVox `brake`).
    pub fn brake(&self) -> Option<f64> {
        self.get_f64("brake")
    }

    /// Appends a pair.
    pub fn push(&mut self, key: impl Into<String>, value: impl ToString) {
        self.entries.push((key.into(), value.to_string()));
    }
}

/// Everything the writer stores for one frame. Only `rgb` is required.
#[derive(Debug, Clone)]
pub struct FrameRecord {
    /// Frame id to write the files under.
    pub id: FrameId,
    /// Camera frame.
    pub rgb: image::RgbImage,
    /// Semantic class ids (AnoVox ids, written as an L PNG).
    pub semantic: Option<image::GrayImage>,
    /// Instance image: R = tag, G + 256·B = instance id.
    pub instance: Option<image::RgbImage>,
    /// Depth in metres, row-major, written in CARLA's 24-bit encoding.
    pub depth_m: Option<Vec<f32>>,
    /// Flow from the previous frame to this one.
    pub flow: Option<super::FlowField>,
    /// Ego state.
    pub action: Option<KeyValues>,
    /// Anomaly actor state.
    pub anomaly: Option<KeyValues>,
    /// Ground-truth boxes of this frame.
    pub boxes: Vec<BoxRecord>,
    /// Explicit frame-level anomaly flag (`frame_labels.csv`).
    pub anomalous: Option<bool>,
}

impl FrameRecord {
    /// A frame with only its camera image: no other modality, no boxes, no label. Set the
    /// rest with struct update syntax (`FrameRecord { boxes, ..FrameRecord::new(id, rgb) }`).
    pub fn new(id: FrameId, rgb: image::RgbImage) -> Self {
        Self {
            id,
            rgb,
            semantic: None,
            instance: None,
            depth_m: None,
            flow: None,
            action: None,
            anomaly: None,
            boxes: Vec::new(),
            anomalous: None,
        }
    }
}
