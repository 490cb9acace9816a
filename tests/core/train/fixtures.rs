//! What the training tests share: synthetic cubes, tiny stage settings, and a judge whose
//! rating follows the model's arithmetic.

use vadscope::model::{Detector, NoiseRng};
use vadscope::train::{
    AnomalySelection, CubeSet, EpochJudge, LrSchedule, StageConfig, TrainConfig,
};

/// Side of the synthetic cubes.
pub const P: usize = 16;

/// Cubes of a sinusoidal texture moving by a per-cube constant velocity, with the matching
/// constant flow plus a little noise; 4 scenarios of 6 cubes.
pub fn synthetic_cubes() -> CubeSet {
    let mut set = CubeSet::new(P, 4);
    let mut rng = NoiseRng::new(42);
    for cube in 0..24 {
        let (vx, vy) = (rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0);
        let phase = rng.uniform() * 6.0;
        let mut frames = Vec::with_capacity(15 * P * P);
        for t in 0..5 {
            for c in 0..3 {
                for y in 0..P {
                    for x in 0..P {
                        let (fx, fy) = (x as f64 - vx * t as f64, y as f64 - vy * t as f64);
                        let v =
                            0.5 + 0.4 * ((fx * 0.7 + phase + c as f64).sin() * (fy * 0.5).cos());
                        frames.push((v * 255.0).round() as u8);
                    }
                }
            }
        }
        let mut flows = Vec::with_capacity(8 * P * P);
        for _ in 0..4 {
            for comp in [vx, vy] {
                let noise = rng.normal_vec(P * P, 0.0, 0.05);
                flows.extend(noise.into_iter().map(|n| comp as f32 + n));
            }
        }
        set.push(&frames, &flows, cube / 6, 0.5).expect("cube");
    }
    set
}

/// Every stage for `epochs`, batches of 6, a quarter of the scenarios held out.
pub fn tiny_training(epochs: usize) -> TrainConfig {
    let stage = |lr: f64| StageConfig {
        epochs,
        batch_size: 6,
        lr,
        schedule: LrSchedule::Step {
            every: 50,
            gamma: 0.8,
        },
        max_steps_per_epoch: None,
    };
    TrainConfig {
        stage1: stage(3e-3),
        stage2: stage(2e-3),
        stage3: stage(1e-3),
        seed: 7,
        val_fraction: 0.25,
        eval_batch: 8,
        ..TrainConfig::default()
    }
}

/// Stage 1 alone for `epochs`, its epochs chosen by `selection`.
pub fn judged_training(epochs: usize, selection: AnomalySelection) -> TrainConfig {
    let base = tiny_training(epochs);
    TrainConfig {
        stage2: StageConfig {
            epochs: 0,
            ..base.stage2.clone()
        },
        stage3: StageConfig {
            epochs: 0,
            ..base.stage3.clone()
        },
        anomaly_selection: Some(selection),
        ..base
    }
}

/// A judge whose rating is a sum of the model's scores over fixed cubes, so any change of
/// the arithmetic shows; it records the threads it ran on.
pub struct ScoreSumJudge {
    /// The cubes scored.
    pub cubes: CubeSet,
    /// Every rating given, in order.
    pub ratings: Vec<f64>,
    /// The threads of each judgement.
    pub threads: Vec<usize>,
}

impl EpochJudge for ScoreSumJudge {
    fn name(&self) -> &str {
        "score sum"
    }

    fn judge(&mut self, detector: &Detector) -> Result<f64, String> {
        let all: Vec<usize> = (0..self.cubes.len()).collect();
        let (frames, flows) = self.cubes.gather(&all);
        let results = detector.infer(&frames, &flows).map_err(|e| e.to_string())?;
        let rating = results
            .iter()
            .map(|r| f64::from(r.s_r) + f64::from(r.s_p))
            .sum::<f64>();
        self.ratings.push(rating);
        self.threads.push(rayon::current_num_threads());
        Ok(rating)
    }
}
