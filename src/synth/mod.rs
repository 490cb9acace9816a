//! The synthetic scenario generator: vadscope's own "CARLA".
//!
//! A seeded, deterministic renderer of ego-view driving scenarios in the AnoVox layout. It
//! builds a road world (city streets with buildings, parked cars, crossings and traffic
//! lights, or highways with guard rails and vegetation), simulates traffic with the
//! Intelligent Driver Model (including the paper's anomaly, sudden braking of the lead
//! vehicle, and hard normal cases: a lead turning off, a vehicle cutting in), and ray-casts
//! every frame from a pinhole camera (FOV 90°, 1.8 m, 10 fps). Per frame it produces RGB,
//! AnoVox semantic ids, instance ids, depth, the exact optical flow from the previous frame
//! (from scene geometry and motion), visible 2D boxes, ACTION/ANOMALY records and the
//! anomaly flag, and writes them through `sequence`.
//!
//! Entry points: [`ScenarioSpec`] / [`plan_dataset`] describe what to generate,
//! [`Scenario::build`] simulates one scenario and renders frames in memory, and
//! [`generate_scenario`] writes a `Scenario_<name>/` folder.

mod camera;
mod error;
mod flow;
mod frame;
mod labels;
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

pub use error::SynthError;
pub use scenario::{GENERATOR_NAME, Scenario, generate_scenario, generate_scenario_without};
pub use spec::{
    DEFAULT_FRAMES, DEFAULT_HEIGHT, DEFAULT_WIDTH, DatasetPlan, DatasetRequest, DomainChoice,
    KindChoice, Preset, ScenarioKind, ScenarioSpec, WeatherChoice, domain_slug, plan_dataset,
    weather_slug,
};
pub use traffic::{
    AnomalyWindow, EGO, FRAME_DT, LEAD, NORMAL_DECEL_LIMIT, Role, Traffic, Vehicle, VehicleState,
    first_collision, max_decel,
};
pub use vehicle::BodyType;
