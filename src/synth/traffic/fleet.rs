//! Building blocks of placing traffic: a fleet that hands out track ids, and the seeded
//! choice of body and driver of a vehicle.

use super::idm::{Idm, NORMAL_DECEL_LIMIT};
use super::route::Route;
use super::types::{Role, Vehicle};
use crate::sequence::Domain;
use crate::synth::rng::Rng;
use crate::synth::vehicle::{BodyType, VehicleModel};

/// A body drawn from the traffic mix of `domain`.
pub(super) fn pick_body(rng: &mut Rng, domain: Domain) -> BodyType {
    let u = rng.unit();
    let (truck, bus, van) = match domain {
        Domain::Highway => (0.17, 0.04, 0.1),
        _ => (0.05, 0.05, 0.1),
    };
    if u < truck {
        BodyType::Truck
    } else if u < truck + bus {
        BodyType::Bus
    } else if u < truck + bus + van {
        BodyType::Van
    } else {
        pick_car(rng)
    }
}

/// A car body (sedan, hatchback or SUV).
pub(super) fn pick_car(rng: &mut Rng) -> BodyType {
    match rng.below(20) {
        0..=8 => BodyType::Sedan,
        9..=14 => BodyType::Hatchback,
        _ => BodyType::Suv,
    }
}

/// A driver of `domain` with desired speed `v0`; heavy vehicles accelerate less.
pub(super) fn idm_for(rng: &mut Rng, domain: Domain, v0: f32, body: BodyType) -> Idm {
    let heavy = matches!(body, BodyType::Truck | BodyType::Bus);
    let (t, s0, a) = match domain {
        Domain::Highway => (rng.range(1.2, 1.7), 2.5, rng.range(1.0, 1.5)),
        _ => (rng.range(1.1, 1.5), 2.0, rng.range(1.3, 1.9)),
    };
    Idm {
        v0,
        t_headway: t,
        s0,
        a_max: if heavy { a * 0.6 } else { a },
        b: 2.0,
        b_max: NORMAL_DECEL_LIMIT,
    }
}

/// Adds vehicles one by one with increasing track ids.
pub(super) struct Fleet {
    /// The vehicles added so far; a vehicle's track id is its index plus one.
    pub(super) vehicles: Vec<Vehicle>,
}

impl Fleet {
    /// Adds a vehicle and returns its index.
    pub(super) fn add(
        &mut self,
        role: Role,
        model: VehicleModel,
        route: Route,
        start: f32,
        idm: Idm,
    ) -> usize {
        let i = self.vehicles.len();
        self.vehicles.push(Vehicle {
            track_id: i as u32 + 1,
            role,
            model,
            route,
            start,
            idm,
        });
        i
    }
}
