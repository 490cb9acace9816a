//! AnoVox class ids and their colours: the CARLA ≥ 0.9.14 CityScapes palette (ids 0–28),
//! AnoVox's anomaly ids (29–34 static categories, 100 generic anomaly), agent ids
//! (CARLA tag + 100) and the ego vehicle (214). Also the old benchmark colours of the
//! anomaly categories, which released colour-coded files may use.

use std::collections::HashMap;
use std::sync::OnceLock;

/// CARLA tag of cars.
pub const CAR: u8 = 14;
/// Generic anomaly id (the lead vehicle while it brakes suddenly).
pub const ANOMALY: u8 = 100;
/// The lead vehicle outside the anomaly window ("agent_car").
pub const AGENT_CAR: u8 = 114;
/// The ego vehicle.
pub const EGO_VEHICLE: u8 = 214;

/// CityScapes colours of CARLA tags 0–28, indexed by tag.
const CITYSCAPES: [[u8; 3]; 29] = [
    [0, 0, 0],
    [128, 64, 128],
    [244, 35, 232],
    [70, 70, 70],
    [102, 102, 156],
    [190, 153, 153],
    [153, 153, 153],
    [250, 170, 30],
    [220, 220, 0],
    [107, 142, 35],
    [152, 251, 152],
    [70, 130, 180],
    [220, 20, 60],
    [255, 0, 0],
    [0, 0, 142],
    [0, 0, 70],
    [0, 60, 100],
    [0, 80, 100],
    [0, 0, 230],
    [119, 11, 32],
    [110, 190, 160],
    [170, 120, 50],
    [55, 90, 80],
    [45, 60, 150],
    [157, 234, 50],
    [81, 0, 81],
    [150, 100, 100],
    [230, 150, 140],
    [180, 165, 180],
];

/// AnoVox's colours of the agent ids (CARLA tag + 100, each one step off the tag's colour);
/// AnoVox defines no agent train (117).
const AGENT_COLOURS: [(u8, [u8; 3]); 7] = [
    (112, [220, 20, 61]),
    (113, [255, 0, 1]),
    (114, [3, 0, 143]),
    (115, [0, 0, 71]),
    (116, [0, 60, 101]),
    (118, [0, 0, 231]),
    (119, [119, 11, 33]),
];
/// Colour of the ego vehicle.
const EGO_COLOUR: [u8; 3] = [0, 0, 1];
/// The older benchmark colours of the static anomaly categories 29–32.
const OLD_ANOMALY_COLOURS: [([u8; 3], u8); 4] = [
    ([250, 128, 114], 29),
    ([255, 36, 0], 30),
    ([224, 17, 95], 31),
    ([184, 15, 10], 32),
];

/// Whether `id` marks an anomaly pixel: the generic id 100 or a static category 29–34.
pub fn is_anomaly_id(id: u8) -> bool {
    id == ANOMALY || (29..=34).contains(&id)
}

/// Whether `id` is a vehicle: CARLA tags 14–19, agents 114–119, or the anomaly id 100
/// (which the generator and AnoVox give to the braking lead vehicle).
pub fn is_vehicle_id(id: u8) -> bool {
    (14..=19).contains(&id) || (114..=119).contains(&id) || id == ANOMALY
}

/// Whether a palette colour marks an anomaly: (245, 0, 0) or (245, k, 0) for a category k.
pub fn is_anomaly_colour(rgb: [u8; 3]) -> bool {
    rgb[0] == 245 && rgb[2] == 0 && (rgb[1] == 0 || (29..=34).contains(&rgb[1]))
}

/// The palette colour of a class id (AnoVox `Definitions.LABELS`); ids without a colour of
/// their own draw black, like unlabeled.
pub fn colour_of(id: u8) -> [u8; 3] {
    match id {
        0..=28 => CITYSCAPES[usize::from(id)],
        29..=34 => [245, id, 0],
        ANOMALY => [245, 0, 0],
        EGO_VEHICLE => EGO_COLOUR,
        _ => AGENT_COLOURS
            .iter()
            .find(|(agent, _)| *agent == id)
            .map_or([0, 0, 0], |(_, colour)| *colour),
    }
}

/// The class id of a palette colour, if the colour is in the palette (current or old).
pub fn id_of_colour(rgb: [u8; 3]) -> Option<u8> {
    colour_table().get(&rgb).copied()
}

fn colour_table() -> &'static HashMap<[u8; 3], u8> {
    static TABLE: OnceLock<HashMap<[u8; 3], u8>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut table: HashMap<[u8; 3], u8> = (0..=28u8).map(|id| (colour_of(id), id)).collect();
        table.extend((29..=34u8).map(|id| (colour_of(id), id)));
        table.extend(OLD_ANOMALY_COLOURS);
        table.insert(colour_of(ANOMALY), ANOMALY);
        table.extend(AGENT_COLOURS.iter().map(|(id, colour)| (*colour, *id)));
        table.insert(EGO_COLOUR, EGO_VEHICLE);
        table
    })
}

/// Colours a class-id image with the palette (the benchmark's colour-coded SEMANTIC_IMG).
pub fn colourise(ids: &image::GrayImage) -> image::RgbImage {
    image::RgbImage::from_fn(ids.width(), ids.height(), |x, y| {
        image::Rgb(colour_of(ids.get_pixel(x, y).0[0]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_palette_id_reads_back() {
        let ids = (0..=34u8).chain([
            ANOMALY,
            112,
            113,
            AGENT_CAR,
            115,
            116,
            118,
            119,
            EGO_VEHICLE,
        ]);
        for id in ids {
            assert_eq!(id_of_colour(colour_of(id)), Some(id), "id {id}");
        }
    }

    #[test]
    fn anomaly_colours_and_ids_agree() {
        assert!(is_anomaly_colour([245, 0, 0]));
        assert!(is_anomaly_colour([245, 31, 0]));
        assert!(!is_anomaly_colour([245, 40, 0]));
        assert!(!is_anomaly_colour([255, 0, 0]));
        assert!(is_anomaly_id(100) && is_anomaly_id(29) && is_anomaly_id(34));
        assert!(!is_anomaly_id(114) && !is_anomaly_id(14));
        assert_eq!(id_of_colour([255, 36, 0]), Some(30));
        assert_eq!(id_of_colour([1, 2, 3]), None);
    }

    #[test]
    fn vehicle_ids_cover_tags_agents_and_anomaly() {
        for id in [14, 15, 16, 17, 18, 19, 114, 119, 100] {
            assert!(is_vehicle_id(id), "{id}");
        }
        for id in [0, 12, 13, 20, 214] {
            assert!(!is_vehicle_id(id), "{id}");
        }
    }
}
