//! Per-frame labels: tight visible 2D boxes from the instance buffer, and the ACTION (ego)
//! and ANOMALY (lead vehicle, sudden-braking scenarios only) key-value records in AnoVox's
//! key set (speeds in km/h, values as Python reprs).

use super::keys::KEY_VEHICLE;
use super::traffic::{EGO, LEAD, Vehicle, VehicleState};
use super::world::World;
use crate::sequence::{BoxRecord, FrameId, KeyValues};

/// Tight boxes (x2/y2 exclusive) of every vehicle visible in the frame, sorted by track id.
pub fn boxes(
    world: &World,
    frame: usize,
    keys: &[u32],
    tags: &[u8],
    width: usize,
) -> Vec<BoxRecord> {
    let n = world.traffic.vehicles.len();
    // Per vehicle: (x0, y0, x1, y1, tag) of its pixels.
    type Extent = (usize, usize, usize, usize, u8);
    let mut ext: Vec<Option<Extent>> = vec![None; n];
    for (i, &key) in keys.iter().enumerate() {
        if key & KEY_VEHICLE == 0 {
            continue;
        }
        let vi = (key & !KEY_VEHICLE) as usize;
        let (x, y) = (i % width, i / width);
        if let Some(slot) = ext.get_mut(vi) {
            *slot = Some(match *slot {
                None => (x, y, x, y, tags[i]),
                Some((x0, y0, x1, y1, t)) => (x0.min(x), y0.min(y), x1.max(x), y1.max(y), t),
            });
        }
    }
    let in_window = world
        .traffic
        .anomaly
        .is_some_and(|a| a.contains(frame as u32));
    let mut out: Vec<BoxRecord> = ext
        .iter()
        .enumerate()
        .filter_map(|(vi, e)| {
            let (x0, y0, x1, y1, tag) = (*e)?;
            Some(BoxRecord {
                frame: FrameId(frame as u64),
                track_id: world.traffic.vehicles[vi].track_id as u64,
                x1: x0 as f32,
                y1: y0 as f32,
                x2: (x1 + 1) as f32,
                y2: (y1 + 1) as f32,
                class: tag as u16,
                score: 1.0,
                anomalous: vi == LEAD && world.labels_lead_as_agent && in_window,
            })
        })
        .collect();
    out.sort_by_key(|b| b.track_id);
    out
}

fn vehicle_record(world: &World, frame: usize, v: &Vehicle, st: &VehicleState) -> KeyValues {
    let mut kv = KeyValues::default();
    kv.push("frame_id", frame);
    kv.push("scenario_id", &world.spec.name);
    kv.push("vehicle_id", v.track_id);
    kv.push("vehicle_type_id", v.model.body.blueprint());
    kv.push("speed", format!("{:?}", st.speed * 3.6));
    kv.push("throttle", format!("{:?}", st.throttle));
    kv.push("steer", format!("{:?}", st.steer));
    kv.push("brake", format!("{:?}", st.brake));
    kv.push("hand_brake", "False");
    kv.push("reverse", "False");
    kv.push("manual_gear_shift", "False");
    kv.push("gear", if st.speed > 0.0 { 1 } else { 0 });
    kv.push("acceleration", format!("{:?}", st.accel));
    kv.push(
        "location",
        format!("({:?}, {:?}, {:?})", st.x, st.y, 0.0f32),
    );
    kv.push(
        "rotation",
        format!("({:?}, {:?}, {:?})", 0.0f32, st.yaw.to_degrees(), 0.0f32),
    );
    kv
}

/// The ego's ACTION record.
pub fn action(world: &World, frame: usize) -> KeyValues {
    let v = &world.traffic.vehicles[EGO];
    vehicle_record(world, frame, v, &world.traffic.states[frame][EGO])
}

/// The lead vehicle's ANOMALY record (sudden-braking scenarios only, as in AnoVox).
pub fn anomaly(world: &World, frame: usize) -> Option<KeyValues> {
    if !world.labels_lead_as_agent {
        return None;
    }
    let v = &world.traffic.vehicles[LEAD];
    Some(vehicle_record(
        world,
        frame,
        v,
        &world.traffic.states[frame][LEAD],
    ))
}
