//! The synthetic scenario generator: vadscope's own "CARLA".
//!
//! A seeded, deterministic renderer of ego-view driving scenarios in the AnoVox layout. It
//! builds a road world (city streets with buildings, parked cars, crossings and traffic
//! lights, or highways with guard rails and vegetation, both with gentle curves), simulates
//! traffic with the Intelligent Driver Model (including the paper's anomaly, sudden braking
//! of the lead vehicle, and hard normal cases: a lead turning off, a vehicle cutting in), and
//! ray-casts every frame from a level pinhole camera (FOV 90°, 1.8 m, 10 fps). Per frame it
//! produces RGB, AnoVox semantic ids, instance ids, depth, the exact optical flow from the
//! previous frame (from scene geometry and motion), tight visible 2D boxes, ACTION/ANOMALY
//! records and the anomaly flag, and writes them through `sequence::writer::ScenarioWriter`.
//!
//! # Use
//!
//! - What to generate: [`ScenarioSpec::new`] (kind, domain, weather, seed; then adjust
//!   `frames`, `width`, `height`), or a whole data set with [`plan_dataset`] /
//!   [`DatasetPlan::from_request`] from a [`DatasetRequest`] (presets `train` and `test`,
//!   `any`/`mixed` choices drawn from the seed; the choice types implement `FromStr` for the
//!   command line).
//! - Writing: [`generate_scenario`]`(&spec, out_dir, on_frame)` writes
//!   `out_dir/Scenario_<name>/` and calls `on_frame(frame)` as frames are written (frames are
//!   rendered in parallel chunks, so the calls come from several threads in any order).
//!   A process that streams many frames calls [`keep_freed_frame_buffers`] once first.
//! - In memory: [`Scenario::build`] simulates; [`Scenario::render_frame`],
//!   [`Scenario::render_range`] and [`Scenario::render_all`] return `FrameRecord`s;
//!   [`Scenario::traffic`] exposes every vehicle's per-frame state and
//!   [`Scenario::anomaly_window`] the labelled window.
//!
//! # Determinism
//!
//! Every random choice comes from the spec's seed through a SplitMix64 stream or integer
//! hashes, and every pixel is a pure function of the scenario and its coordinates, so the
//! same spec gives identical bytes for any thread count.
//!
//! # Conventions
//!
//! Frame ids are 0-based. The lead vehicle of a sudden-braking scenario is labelled 114
//! (agent car) in SEMANTIC_IMG and 100 (anomaly) from brake onset to standstill, as AnoVox
//! does; other vehicles carry their CARLA tags (14 car, 15 truck, 16 bus). The ego's own body
//! is never in view (the camera looks over it), so id 214 does not occur. Depth is the
//! distance along the optical axis (1000 m for sky). Flow is defined on the pixel grid of the
//! previous frame and is invalid on sky, where the surface point leaves the image, and where
//! it is hidden in the next frame.

mod camera;
mod error;
mod flow;
mod frame;
mod gbuffer;
mod heap_policy;
mod keys;
mod labels;
mod light_bank;
mod lighting;
mod math;
mod post;
mod render;
mod rng;
mod road;
mod scenario;
mod scenery;
mod shade;
mod spec;
mod texture;
mod traffic;
mod vehicle;
mod world;

pub use error::SynthError;
pub use heap_policy::keep_freed_frame_buffers;
pub use scenario::{
    GENERATOR_NAME, Scenario, check_generated, generate_scenario, generate_scenario_without,
};
pub use spec::{
    DEFAULT_FRAMES, DEFAULT_HEIGHT, DEFAULT_WIDTH, DatasetPlan, DatasetRequest, DomainChoice,
    KindChoice, MAX_FRAMES, ParseChoiceError, Preset, ScenarioKind, ScenarioSpec, WeatherChoice,
    domain_slug, parse_size, plan_dataset, weather_slug,
};
pub use traffic::{
    AnomalyWindow, CROSS_STREET_END, EGO, FRAME_DT, LEAD, NORMAL_DECEL_LIMIT, Role, Route, Traffic,
    Vehicle, VehicleState, first_collision, max_decel,
};
pub use vehicle::{BodyType, VehicleModel};
