//! What to generate: one scenario ([`ScenarioSpec`]) and whole data sets
//! ([`DatasetRequest`] → [`plan_dataset`]), including the two presets shaped like the
//! paper's data (`train`: normal driving only; `test`: 13 sudden-braking scenarios).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::SynthError;
use super::rng::{Rng, mix64};
use crate::sequence::{AnomalyType, Domain, Weather};

/// What happens in a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScenarioKind {
    /// Normal driving: car following, traffic lights, oncoming and cross traffic.
    Normal,
    /// The anomaly of the paper: the lead vehicle brakes hard (>= 7 m/s²) to a standstill.
    Braking,
    /// Hard normal case: the lead vehicle turns off (city) or changes out of the ego lane
    /// (highway).
    Turning,
    /// Hard normal case: a vehicle from an adjacent lane cuts in ahead of the ego.
    CutIn,
}

impl ScenarioKind {
    /// The AnoVox / vadscope anomaly type recorded in `scenario.json`.
    pub fn anomaly_type(self) -> AnomalyType {
        match self {
            ScenarioKind::Normal => AnomalyType::Normality,
            ScenarioKind::Braking => AnomalyType::SuddenBraking,
            ScenarioKind::Turning => AnomalyType::LeadTurning,
            ScenarioKind::CutIn => AnomalyType::CutIn,
        }
    }

    /// The name the command line and `scenario.json` use (`--kind cut-in`).
    pub fn name(self) -> &'static str {
        match self {
            ScenarioKind::CutIn => "cut-in",
            kind => kind.slug(),
        }
    }

    /// The fewest frames a scenario of this kind needs: a sudden brake needs the approach
    /// before it and the stop after it, a turn or a cut-in the manoeuvre and the lane it
    /// clears.
    pub fn min_frames(self) -> u32 {
        match self {
            ScenarioKind::Normal => 1,
            ScenarioKind::Braking => 80,
            ScenarioKind::Turning | ScenarioKind::CutIn => 120,
        }
    }

    /// Short lowercase name used in folder names.
    pub fn slug(self) -> &'static str {
        match self {
            ScenarioKind::Normal => "normal",
            ScenarioKind::Braking => "braking",
            ScenarioKind::Turning => "turning",
            ScenarioKind::CutIn => "cutin",
        }
    }
}

/// Default number of frames of a scenario (AnoVox records 200 frames at 10 Hz).
pub const DEFAULT_FRAMES: u32 = 200;
/// The most frames of one scenario: 200 s, ten times AnoVox's recordings. Longer ones
/// need a longer road, and the randomly bending road of a 4,000-frame scenario can meet
/// itself (its traffic then collides, and no variant satisfies the scenario).
pub const MAX_FRAMES: u32 = 2000;
/// Default image width (AnoVox's camera).
pub const DEFAULT_WIDTH: u32 = 768;
/// Default image height (AnoVox's camera).
pub const DEFAULT_HEIGHT: u32 = 512;

/// Everything that determines one generated scenario. Two equal specs give identical bytes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioSpec {
    /// Scenario name; the folder is `Scenario_<name>`.
    pub name: String,
    /// What happens.
    pub kind: ScenarioKind,
    /// City or highway (`Unknown` is not allowed).
    pub domain: Domain,
    /// Sun, rain, fog or night (`Unknown` is not allowed).
    pub weather: Weather,
    /// Number of frames.
    pub frames: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Seed of everything random in the scenario.
    pub seed: u64,
    /// Town name recorded in the metadata (scenarios of one town share road style).
    pub town: String,
}

impl ScenarioSpec {
    /// A spec with default size and frame count and a name derived from its contents.
    pub fn new(kind: ScenarioKind, domain: Domain, weather: Weather, seed: u64) -> Self {
        let mut spec = Self {
            name: String::new(),
            kind,
            domain,
            weather,
            frames: DEFAULT_FRAMES,
            width: DEFAULT_WIDTH,
            height: DEFAULT_HEIGHT,
            seed,
            town: format!("SynthTown{:02}", seed % 8),
        };
        spec.name = spec.default_name(0);
        spec
    }

    /// `<index>_<kind>_<domain>_<weather>_<seed>` (index keeps a data set's order).
    pub fn default_name(&self, index: usize) -> String {
        format!(
            "{index:04}_{}_{}_{}_{:016x}",
            self.kind.slug(),
            domain_slug(self.domain),
            weather_slug(self.weather),
            self.seed
        )
    }

    /// The folder the scenario is written to under `out_dir`: `Scenario_<name>`.
    pub fn folder_in(&self, out_dir: &Path) -> PathBuf {
        out_dir.join(format!("Scenario_{}", self.name))
    }

    /// Checks that the spec can be generated.
    pub fn validate(&self) -> Result<(), SynthError> {
        let bad = |problem: String| Err(SynthError::InvalidSpec { problem });
        if self.width < 16 || self.height < 16 || self.width > 8192 || self.height > 8192 {
            return bad(format!(
                "image size {}x{} is outside 16..8192",
                self.width, self.height
            ));
        }
        if self.frames == 0 || self.frames > MAX_FRAMES {
            return bad(format!(
                "frame count {} is outside 1..{MAX_FRAMES} (the longest scenario the \
                 generator supports, 200 s; generate several for more)",
                self.frames
            ));
        }
        if matches!(self.domain, Domain::Unknown) {
            return bad("domain must be city or highway".into());
        }
        if matches!(self.weather, Weather::Unknown) {
            return bad("weather must be sun, rain, fog or night".into());
        }
        let min_frames = self.kind.min_frames();
        if self.frames < min_frames {
            return bad(format!(
                "a {} scenario needs at least {min_frames} frames, got {}",
                self.kind.name(),
                self.frames
            ));
        }
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return bad(format!(
                "scenario name {:?} must be non-empty ASCII letters, digits, '_' or '-'",
                self.name
            ));
        }
        Ok(())
    }
}

/// Lowercase domain name.
pub fn domain_slug(d: Domain) -> &'static str {
    match d {
        Domain::City => "city",
        Domain::Highway => "highway",
        Domain::Unknown => "unknown",
    }
}

/// Lowercase weather name.
pub fn weather_slug(w: Weather) -> &'static str {
    match w {
        Weather::Sun => "sun",
        Weather::Rain => "rain",
        Weather::Fog => "fog",
        Weather::Night => "night",
        Weather::Unknown => "unknown",
    }
}

/// A data-set preset shaped like the paper's data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// Normal driving only, several towns, city and highway in every weather, turning and
    /// cut-in leads among them.
    Train,
    /// 13 sudden-braking scenarios over city/highway × sun/rain with normal traffic.
    Test,
}

/// A kind choice of a data-set request; `Mixed` draws normal, braking, turning and cut-in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KindChoice {
    /// Only this kind.
    Only(ScenarioKind),
    /// A seeded mix of all kinds.
    Mixed,
}

impl KindChoice {
    /// How a `Mixed` choice draws: the first kind whose cumulative probability exceeds a
    /// uniform draw (normal 40 %, braking 30 %, turning 15 %, cut-in 15 %).
    pub const MIXED_DRAW: [(f32, ScenarioKind); 4] = [
        (0.4, ScenarioKind::Normal),
        (0.7, ScenarioKind::Braking),
        (0.85, ScenarioKind::Turning),
        (1.0, ScenarioKind::CutIn),
    ];

    /// The fewest frames every scenario this choice can give needs.
    pub fn min_frames(self) -> u32 {
        match self {
            KindChoice::Only(kind) => kind.min_frames(),
            KindChoice::Mixed => Self::MIXED_DRAW
                .iter()
                .map(|(_, kind)| kind.min_frames())
                .max()
                .unwrap_or(1),
        }
    }
}

/// A domain choice; `Any` is a seeded draw per scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DomainChoice {
    /// City streets.
    City,
    /// Highway.
    Highway,
    /// Seeded draw.
    Any,
}

/// A weather choice; `Any` is a seeded draw per scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WeatherChoice {
    /// Clear day.
    Sun,
    /// Rain.
    Rain,
    /// Fog.
    Fog,
    /// Night.
    Night,
    /// Seeded draw.
    Any,
}

/// What the CLI asks for (`vadscope generate`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetRequest {
    /// A preset; its choices apply unless overridden by the explicit fields below.
    pub preset: Option<Preset>,
    /// Number of scenarios (presets have defaults: train 24, test 13).
    pub count: Option<usize>,
    /// Kind of scenario (default: the preset's, else normal).
    pub kind: Option<KindChoice>,
    /// Domain (default: the preset's, else any).
    pub domain: Option<DomainChoice>,
    /// Weather (default: the preset's, else any).
    pub weather: Option<WeatherChoice>,
    /// Frames per scenario (default 200).
    pub frames: Option<u32>,
    /// Image size (default 768×512).
    pub size: Option<(u32, u32)>,
    /// Base seed of the data set (default 0).
    pub seed: u64,
}

impl DatasetRequest {
    /// A request for `count` scenarios with every other choice left to its default.
    pub fn new(count: usize, seed: u64) -> Self {
        Self {
            preset: None,
            count: Some(count),
            kind: None,
            domain: None,
            weather: None,
            frames: None,
            size: None,
            seed,
        }
    }
}

/// The scenario list of a data set; see [`plan_dataset`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetPlan {
    /// The scenarios, in order.
    pub scenarios: Vec<ScenarioSpec>,
}

impl DatasetPlan {
    /// Plans the data set for `request`.
    pub fn from_request(request: &DatasetRequest) -> Result<Self, SynthError> {
        Ok(Self {
            scenarios: plan_dataset(request)?,
        })
    }
}

/// Expands a request into concrete scenario specs. Every `Any`/`Mixed` choice is a seeded
/// draw, so the same request always gives the same list.
///
/// - `train`: normal driving only (no anomaly): city and highway alternating in sun, rain,
///   fog and night, town cycling over 6 towns; in every eight scenarios one turning and one
///   cut-in lead when the recordings are long enough for them (120 frames). Half of the
///   scenarios follow their lead closely by AnoVox's rule, and half of the leads slow
///   down gently for a moment (`traffic`).
/// - `test`: 13 sudden-braking scenarios cycling through city/highway × sun/rain.
pub fn plan_dataset(request: &DatasetRequest) -> Result<Vec<ScenarioSpec>, SynthError> {
    let count = request.count.unwrap_or(match request.preset {
        Some(Preset::Train) => 24,
        Some(Preset::Test) => 13,
        None => 1,
    });
    if count == 0 || count > 100_000 {
        return Err(SynthError::InvalidSpec {
            problem: format!("scenario count {count} is outside 1..100000"),
        });
    }
    let frames = request.frames.unwrap_or(DEFAULT_FRAMES);
    if request.kind == Some(KindChoice::Mixed) {
        // Refused up front: otherwise whether the request works would depend on whether the
        // seed happens to draw a kind that needs more frames.
        let min_frames = KindChoice::Mixed.min_frames();
        if frames < min_frames {
            return Err(SynthError::InvalidSpec {
                problem: format!(
                    "a mixed data set draws turning and cut-in scenarios, which need at least \
                     {min_frames} frames, got {frames}; ask for more frames or one kind"
                ),
            });
        }
    }
    let (width, height) = request.size.unwrap_or((DEFAULT_WIDTH, DEFAULT_HEIGHT));
    let mut rng = Rng::new(request.seed ^ 0x0da7_a5e7);
    let mut specs = Vec::with_capacity(count);
    let combos = [
        (Domain::City, Weather::Sun),
        (Domain::Highway, Weather::Sun),
        (Domain::City, Weather::Rain),
        (Domain::Highway, Weather::Rain),
    ];
    for i in 0..count {
        let seed = mix64(
            request
                .seed
                .wrapping_mul(0x100_0000_01b3)
                .wrapping_add(i as u64 + 1),
        );
        let (preset_kind, preset_domain, preset_weather, town) = match request.preset {
            Some(Preset::Train) => {
                // Both domains in every weather; a turning and a cut-in lead in every eight
                // scenarios where the recording is long enough to show them.
                let d = [Domain::City, Domain::Highway][i % 2];
                let w = [Weather::Sun, Weather::Rain, Weather::Fog, Weather::Night][(i / 2) % 4];
                let kind = match i % 8 {
                    5 if frames >= ScenarioKind::Turning.min_frames() => ScenarioKind::Turning,
                    7 if frames >= ScenarioKind::CutIn.min_frames() => ScenarioKind::CutIn,
                    _ => ScenarioKind::Normal,
                };
                (
                    kind,
                    Some(d),
                    Some(w),
                    format!("SynthTown{:02}", 1 + (i / 8) % 6),
                )
            }
            Some(Preset::Test) => {
                let (d, w) = combos[i % 4];
                (
                    ScenarioKind::Braking,
                    Some(d),
                    Some(w),
                    format!("SynthTown{:02}", 10 + i % 3),
                )
            }
            None => (
                ScenarioKind::Normal,
                None,
                None,
                format!("SynthTown{:02}", i % 8),
            ),
        };
        let kind = match request.kind {
            Some(KindChoice::Only(k)) => k,
            Some(KindChoice::Mixed) => {
                let u = rng.unit();
                KindChoice::MIXED_DRAW
                    .iter()
                    .find(|(below, _)| u < *below)
                    .map_or(ScenarioKind::CutIn, |&(_, kind)| kind)
            }
            None => preset_kind,
        };
        let draw_domain = |rng: &mut Rng| {
            if rng.chance(0.5) {
                Domain::City
            } else {
                Domain::Highway
            }
        };
        let domain = match request.domain {
            Some(DomainChoice::City) => Domain::City,
            Some(DomainChoice::Highway) => Domain::Highway,
            Some(DomainChoice::Any) => draw_domain(&mut rng),
            None => match preset_domain {
                Some(d) => d,
                None => draw_domain(&mut rng),
            },
        };
        let draw_weather = |rng: &mut Rng| match rng.below(4) {
            0 => Weather::Sun,
            1 => Weather::Rain,
            2 => Weather::Fog,
            _ => Weather::Night,
        };
        let weather = match request.weather {
            Some(WeatherChoice::Sun) => Weather::Sun,
            Some(WeatherChoice::Rain) => Weather::Rain,
            Some(WeatherChoice::Fog) => Weather::Fog,
            Some(WeatherChoice::Night) => Weather::Night,
            Some(WeatherChoice::Any) => draw_weather(&mut rng),
            None => match preset_weather {
                Some(w) => w,
                None => draw_weather(&mut rng),
            },
        };
        let mut spec = ScenarioSpec {
            name: String::new(),
            kind,
            domain,
            weather,
            frames,
            width,
            height,
            seed,
            town,
        };
        spec.name = spec.default_name(i);
        spec.validate()?;
        specs.push(spec);
    }
    Ok(specs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_preset_is_thirteen_braking_scenarios_over_four_conditions() {
        let req = DatasetRequest {
            preset: Some(Preset::Test),
            ..DatasetRequest::new(13, 5)
        };
        let plan = plan_dataset(&DatasetRequest { count: None, ..req }).unwrap();
        assert_eq!(plan.len(), 13);
        assert!(plan.iter().all(|s| s.kind == ScenarioKind::Braking));
        for d in [Domain::City, Domain::Highway] {
            for w in [Weather::Sun, Weather::Rain] {
                assert!(plan.iter().any(|s| s.domain == d && s.weather == w));
            }
        }
        let names: std::collections::HashSet<_> = plan.iter().map(|s| s.name.clone()).collect();
        assert_eq!(names.len(), 13);
    }

    #[test]
    fn train_preset_is_normal_driving_in_every_condition_and_choices_are_honoured() {
        let req = DatasetRequest {
            preset: Some(Preset::Train),
            frames: Some(120),
            ..DatasetRequest::new(24, 9)
        };
        let plan = plan_dataset(&req).unwrap();
        assert!(plan.iter().all(|s| s.kind != ScenarioKind::Braking));
        for kind in [
            ScenarioKind::Normal,
            ScenarioKind::Turning,
            ScenarioKind::CutIn,
        ] {
            assert!(plan.iter().any(|s| s.kind == kind), "{kind:?}");
        }
        for d in [Domain::City, Domain::Highway] {
            for w in [Weather::Sun, Weather::Rain, Weather::Fog, Weather::Night] {
                assert!(plan.iter().any(|s| s.domain == d && s.weather == w));
            }
        }
        let towns: std::collections::HashSet<_> = plan.iter().map(|s| s.town.clone()).collect();
        assert!(towns.len() >= 3);
        // Recordings too short for a turn keep to normal driving.
        let short = DatasetRequest {
            frames: Some(24),
            ..req.clone()
        };
        assert!(
            plan_dataset(&short)
                .unwrap()
                .iter()
                .all(|s| s.kind == ScenarioKind::Normal)
        );
        let req = DatasetRequest {
            kind: Some(KindChoice::Only(ScenarioKind::CutIn)),
            domain: Some(DomainChoice::Highway),
            weather: Some(WeatherChoice::Fog),
            ..DatasetRequest::new(4, 1)
        };
        let plan = plan_dataset(&req).unwrap();
        assert!(plan.iter().all(|s| s.kind == ScenarioKind::CutIn
            && s.domain == Domain::Highway
            && s.weather == Weather::Fog));
        assert_eq!(plan, plan_dataset(&req).unwrap());
    }

    #[test]
    fn bad_requests_are_errors() {
        assert!(plan_dataset(&DatasetRequest::new(0, 1)).is_err());
        let req = DatasetRequest {
            kind: Some(KindChoice::Only(ScenarioKind::Braking)),
            frames: Some(10),
            ..DatasetRequest::new(1, 1)
        };
        assert!(plan_dataset(&req).is_err());
        let longest = |frames| DatasetRequest {
            kind: Some(KindChoice::Mixed),
            frames: Some(frames),
            ..DatasetRequest::new(3, 1)
        };
        assert!(plan_dataset(&longest(MAX_FRAMES)).is_ok());
        let message = plan_dataset(&longest(MAX_FRAMES + 1))
            .unwrap_err()
            .to_string();
        assert!(message.contains("2001 is outside 1..2000"), "{message}");
    }

    #[test]
    fn too_short_requests_name_the_kind_and_its_minimum() {
        let request = |kind, frames, seed| DatasetRequest {
            kind: Some(kind),
            frames: Some(frames),
            ..DatasetRequest::new(6, seed)
        };
        let cut_in = plan_dataset(&request(KindChoice::Only(ScenarioKind::CutIn), 100, 1));
        let message = cut_in.unwrap_err().to_string();
        assert!(
            message.contains("a cut-in scenario needs at least 120 frames, got 100"),
            "{message}"
        );
        // A mixed request is refused whatever its seed draws, and works from the minimum on.
        for seed in 0..8 {
            let short = plan_dataset(&request(KindChoice::Mixed, 80, seed));
            let message = short.unwrap_err().to_string();
            assert!(
                message.contains("mixed") && message.contains("at least 120 frames, got 80"),
                "{message}"
            );
            let plan = plan_dataset(&request(KindChoice::Mixed, 120, seed)).unwrap();
            assert!(plan.iter().all(|s| s.validate().is_ok()));
        }
    }
}

/// Error of parsing a command-line choice: the text and the accepted values.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} {text:?}; expected one of: {expected}")]
pub struct ParseChoiceError {
    /// Which option was parsed.
    pub what: &'static str,
    /// The text given.
    pub text: String,
    /// The accepted values.
    pub expected: &'static str,
}

fn parse_choice<T: Copy>(
    what: &'static str,
    expected: &'static str,
    text: &str,
    table: &[(&str, T)],
) -> Result<T, ParseChoiceError> {
    let lower = text.trim().to_ascii_lowercase();
    table
        .iter()
        .find(|(name, _)| *name == lower)
        .map(|(_, v)| *v)
        .ok_or_else(|| ParseChoiceError {
            what,
            text: text.to_string(),
            expected,
        })
}

impl std::str::FromStr for KindChoice {
    type Err = ParseChoiceError;

    /// `normal`, `braking`, `turning`, `cut-in` or `mixed`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_choice(
            "kind",
            "normal, braking, turning, cut-in, mixed",
            s,
            &[
                ("normal", KindChoice::Only(ScenarioKind::Normal)),
                ("braking", KindChoice::Only(ScenarioKind::Braking)),
                ("turning", KindChoice::Only(ScenarioKind::Turning)),
                ("cut-in", KindChoice::Only(ScenarioKind::CutIn)),
                ("cutin", KindChoice::Only(ScenarioKind::CutIn)),
                ("mixed", KindChoice::Mixed),
            ],
        )
    }
}

impl std::str::FromStr for DomainChoice {
    type Err = ParseChoiceError;

    /// `city`, `highway` or `any`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_choice(
            "domain",
            "city, highway, any",
            s,
            &[
                ("city", DomainChoice::City),
                ("highway", DomainChoice::Highway),
                ("any", DomainChoice::Any),
            ],
        )
    }
}

impl std::str::FromStr for WeatherChoice {
    type Err = ParseChoiceError;

    /// `sun`, `rain`, `fog`, `night` or `any`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_choice(
            "weather",
            "sun, rain, fog, night, any",
            s,
            &[
                ("sun", WeatherChoice::Sun),
                ("rain", WeatherChoice::Rain),
                ("fog", WeatherChoice::Fog),
                ("night", WeatherChoice::Night),
                ("any", WeatherChoice::Any),
            ],
        )
    }
}

impl std::str::FromStr for Preset {
    type Err = ParseChoiceError;

    /// `train` or `test`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_choice(
            "preset",
            "train, test",
            s,
            &[("train", Preset::Train), ("test", Preset::Test)],
        )
    }
}

/// Parses an image size written `WxH` (e.g. `768x512`).
pub fn parse_size(text: &str) -> Result<(u32, u32), ParseChoiceError> {
    let bad = || ParseChoiceError {
        what: "size",
        text: text.to_string(),
        expected: "WIDTHxHEIGHT, e.g. 768x512",
    };
    let (w, h) = text.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    Ok((w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?))
}

#[cfg(test)]
mod parse_tests {
    use super::*;

    #[test]
    fn command_line_choices_parse() {
        assert_eq!("cut-in".parse(), Ok(KindChoice::Only(ScenarioKind::CutIn)));
        assert_eq!("Mixed".parse(), Ok(KindChoice::Mixed));
        assert_eq!("any".parse(), Ok(DomainChoice::Any));
        assert_eq!("night".parse(), Ok(WeatherChoice::Night));
        assert_eq!("test".parse(), Ok(Preset::Test));
        assert_eq!(parse_size("768x512"), Ok((768, 512)));
        assert!("snow".parse::<WeatherChoice>().is_err());
        assert!(parse_size("768").is_err());
        let err = "boat".parse::<KindChoice>().unwrap_err();
        assert!(err.to_string().contains("cut-in"));
    }
}
