//! `CubeSet`: an in-memory set of spatio-temporal cubes (frames as bytes, flows as f32,
//! a scenario group and the box centre's column per cube) with its file format, batching
//! and the validation split.
//!
//! On disk a cube set is a safetensors file (`frames` U8 [N, 3(t+1), P, P], `flows` F32
//! [N, 2t, P, P], `groups` U32 [N], `centres` F32 [N]) with `vadscope.format =
//! vadscope-cubes/2`; `vadscope-cubes/1` files (without `centres`) still load, their centres
//! unknown. Cubes are always stored in vadscope's conventions: RGB frames, flows in native
//! pixels.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::json;

use crate::atomic_file::write_atomically;
use crate::model::rng::NoiseRng;

use super::error::TrainError;

const FORMAT: &str = "vadscope-cubes/2";
/// The first format, without box centres.
const FORMAT_WITHOUT_CENTRES: &str = "vadscope-cubes/1";

/// A set of cubes of one patch size and history length.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeSet {
    patch: usize,
    clip_hist: usize,
    frames: Vec<u8>,
    flows: Vec<f32>,
    groups: Vec<u32>,
    /// Box centre per cube as a fraction of the frame width (NaN where unknown).
    centres: Vec<f32>,
}

impl CubeSet {
    /// An empty set of `patch`×`patch` cubes with `clip_hist` past frames.
    pub fn new(patch: usize, clip_hist: usize) -> Self {
        Self {
            patch,
            clip_hist,
            frames: Vec::new(),
            flows: Vec::new(),
            groups: Vec::new(),
            centres: Vec::new(),
        }
    }

    /// Patch side.
    pub fn patch(&self) -> usize {
        self.patch
    }

    /// Past frames per cube.
    pub fn clip_hist(&self) -> usize {
        self.clip_hist
    }

    /// Bytes of one cube's frames: 3·(t+1)·P².
    pub fn frame_len(&self) -> usize {
        3 * (self.clip_hist + 1) * self.patch * self.patch
    }

    /// Values of one cube's flows: 2·t·P².
    pub fn flow_len(&self) -> usize {
        2 * self.clip_hist * self.patch * self.patch
    }

    /// Number of cubes.
    pub fn len(&self) -> usize {
        self.groups.len()
    }

    /// Whether the set holds no cube.
    pub fn is_empty(&self) -> bool {
        self.groups.is_empty()
    }

    /// Adds a cube: `frames` RGB bytes [3(t+1), P, P] (oldest first), `flows` [2t, P, P] in
    /// native pixels, `group` the scenario it came from (keeps the split leak-free),
    /// `centre` its box centre as a fraction of the frame width.
    pub fn push(
        &mut self,
        frames: &[u8],
        flows: &[f32],
        group: u32,
        centre: f32,
    ) -> Result<(), TrainError> {
        if frames.len() != self.frame_len() || flows.len() != self.flow_len() {
            return Err(TrainError::Data(format!(
                "cube of {} frame bytes and {} flow values; expected {} and {}",
                frames.len(),
                flows.len(),
                self.frame_len(),
                self.flow_len()
            )));
        }
        if flows.iter().any(|v| !v.is_finite()) {
            return Err(TrainError::Data(
                "cube flow holds a non-finite value".into(),
            ));
        }
        self.frames.extend_from_slice(frames);
        self.flows.extend_from_slice(flows);
        self.groups.push(group);
        self.centres.push(centre);
        Ok(())
    }

    /// Appends every cube of `other` (same patch and history).
    pub fn extend(&mut self, other: &CubeSet) -> Result<(), TrainError> {
        if other.patch != self.patch || other.clip_hist != self.clip_hist {
            return Err(TrainError::Data(format!(
                "cannot merge cubes of patch {}/history {} into patch {}/history {}",
                other.patch, other.clip_hist, self.patch, self.clip_hist
            )));
        }
        self.frames.extend_from_slice(&other.frames);
        self.flows.extend_from_slice(&other.flows);
        self.groups.extend_from_slice(&other.groups);
        self.centres.extend_from_slice(&other.centres);
        Ok(())
    }

    /// Frames of cube `i` as bytes.
    pub fn frames_of(&self, i: usize) -> &[u8] {
        &self.frames[i * self.frame_len()..(i + 1) * self.frame_len()]
    }

    /// Flows of cube `i`.
    pub fn flows_of(&self, i: usize) -> &[f32] {
        &self.flows[i * self.flow_len()..(i + 1) * self.flow_len()]
    }

    /// Scenario group of cube `i`.
    pub fn group_of(&self, i: usize) -> u32 {
        self.groups[i]
    }

    /// Box centre of cube `i` as a fraction of the frame width; `None` for cubes read from
    /// a file that predates centres.
    pub fn centre_of(&self, i: usize) -> Option<f32> {
        Some(self.centres[i]).filter(|c| c.is_finite())
    }

    /// Frames (as f32 in [0, 1]) and flows of the cubes `indices`, concatenated.
    pub fn gather(&self, indices: &[usize]) -> (Vec<f32>, Vec<f32>) {
        let mut frames = Vec::with_capacity(indices.len() * self.frame_len());
        let mut flows = Vec::with_capacity(indices.len() * self.flow_len());
        for &i in indices {
            frames.extend(self.frames_of(i).iter().map(|&v| v as f32 / 255.0));
            flows.extend_from_slice(self.flows_of(i));
        }
        (frames, flows)
    }

    /// Splits the cube indices into (train, validation). With several scenario groups, a
    /// seeded random `fraction` of the groups (at least one, never all) is held out, so no
    /// scenario feeds both sides; with one group, the last `fraction` of its cubes is.
    pub fn split(&self, fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
        let n = self.len();
        if fraction <= 0.0 || n < 2 {
            return ((0..n).collect(), Vec::new());
        }
        let mut groups: Vec<u32> = self.groups.clone();
        groups.sort_unstable();
        groups.dedup();
        if groups.len() >= 2 {
            NoiseRng::new(seed).shuffle(&mut groups);
            let held =
                ((groups.len() as f64 * fraction).round() as usize).clamp(1, groups.len() - 1);
            let held: std::collections::BTreeSet<u32> = groups[..held].iter().copied().collect();
            (0..n).partition(|&i| !held.contains(&self.groups[i]))
        } else {
            let held = ((n as f64 * fraction).round() as usize).clamp(1, n - 1);
            ((0..n - held).collect(), (n - held..n).collect())
        }
    }

    /// Writes the set to `path` (scratch file, then rename).
    pub fn save(&self, path: &Path) -> Result<(), TrainError> {
        let n = self.len();
        let (p, t) = (self.patch, self.clip_hist);
        let frame_bytes = self.frames.len();
        let flow_bytes = self.flows.len() * 4;
        let group_bytes = self.groups.len() * 4;
        let centre_bytes = self.centres.len() * 4;
        let centres_at = frame_bytes + flow_bytes + group_bytes;
        let header = json!({
            "__metadata__": {
                "vadscope.format": FORMAT,
                "patch_size": p.to_string(),
                "clip_hist": t.to_string(),
            },
            "frames": {"dtype": "U8", "shape": [n, 3 * (t + 1), p, p], "data_offsets": [0, frame_bytes]},
            "flows": {"dtype": "F32", "shape": [n, 2 * t, p, p],
                      "data_offsets": [frame_bytes, frame_bytes + flow_bytes]},
            "groups": {"dtype": "U32", "shape": [n],
                       "data_offsets": [frame_bytes + flow_bytes, centres_at]},
            "centres": {"dtype": "F32", "shape": [n],
                        "data_offsets": [centres_at, centres_at + centre_bytes]},
        });
        let mut header = serde_json::to_vec(&header).map_err(|e| TrainError::io(path, e))?;
        // safetensors pads the header with spaces to an 8-byte boundary.
        while header.len() % 8 != 0 {
            header.push(b' ');
        }
        let mut bytes = Vec::with_capacity(8 + header.len() + centres_at + centre_bytes);
        bytes.extend_from_slice(&(header.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&header);
        bytes.extend_from_slice(&self.frames);
        bytes.extend(self.flows.iter().flat_map(|v| v.to_le_bytes()));
        bytes.extend(self.groups.iter().flat_map(|v| v.to_le_bytes()));
        bytes.extend(self.centres.iter().flat_map(|v| v.to_le_bytes()));
        Ok(write_atomically(path, &bytes)?)
    }

    /// Reads a set written by [`CubeSet::save`].
    pub fn load(path: &Path) -> Result<Self, TrainError> {
        let bytes = std::fs::read(path).map_err(|e| TrainError::io(path, e))?;
        let bad = |msg: String| TrainError::file(path, msg);
        let len = bytes
            .get(..8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])) as usize)
            .ok_or_else(|| bad("shorter than a safetensors header".into()))?;
        let header = bytes
            .get(8..8usize.saturating_add(len))
            .ok_or_else(|| bad(format!("header of {len} bytes runs past the end")))?;
        let data = &bytes[8 + len..];
        let header: BTreeMap<String, serde_json::Value> =
            serde_json::from_slice(header).map_err(|e| bad(format!("header is not JSON: {e}")))?;
        let meta = header
            .get("__metadata__")
            .ok_or_else(|| bad("no metadata: not a cube set".into()))?;
        let with_centres = match meta.get("vadscope.format").and_then(|v| v.as_str()) {
            Some(FORMAT) => true,
            Some(FORMAT_WITHOUT_CENTRES) => false,
            _ => return Err(bad(format!("not a cube set (format is not {FORMAT})"))),
        };
        let number = |key: &str| {
            meta.get(key)
                .and_then(|v| v.as_str())
                .and_then(|v| v.parse::<usize>().ok())
                .filter(|&v| v > 0 && v <= 4096)
                .ok_or_else(|| bad(format!("metadata '{key}' missing or invalid")))
        };
        let mut set = CubeSet::new(number("patch_size")?, number("clip_hist")?);
        let section =
            |name: &str, dtype: &str, elem: usize| -> Result<(&[u8], usize), TrainError> {
                let entry = header
                    .get(name)
                    .ok_or_else(|| bad(format!("tensor '{name}' missing")))?;
                if entry.get("dtype").and_then(|v| v.as_str()) != Some(dtype) {
                    return Err(bad(format!("tensor '{name}' is not {dtype}")));
                }
                let shape: Vec<usize> = entry
                    .get("shape")
                    .and_then(|v| v.as_array())
                    .map(|a| {
                        a.iter()
                            .filter_map(|d| d.as_u64().map(|d| d as usize))
                            .collect()
                    })
                    .ok_or_else(|| bad(format!("tensor '{name}' has no shape")))?;
                let offsets: Vec<usize> = entry
                    .get("data_offsets")
                    .and_then(|v| v.as_array())
                    .map(|a| {
                        a.iter()
                            .filter_map(|d| d.as_u64().map(|d| d as usize))
                            .collect()
                    })
                    .unwrap_or_default();
                let [start, end] = offsets[..] else {
                    return Err(bad(format!("tensor '{name}' has bad data offsets")));
                };
                let count = shape.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
                let slice = data
                    .get(start..end)
                    .filter(|s| Some(s.len()) == count.map(|c| c * elem));
                let slice = slice
                    .ok_or_else(|| bad(format!("tensor '{name}' data does not match its shape")))?;
                Ok((slice, shape.first().copied().unwrap_or(0)))
            };
        let (frames, n_frames) = section("frames", "U8", 1)?;
        let (flows, n_flows) = section("flows", "F32", 4)?;
        let (groups, n_groups) = section("groups", "U32", 4)?;
        if n_frames != n_flows
            || n_flows != n_groups
            || frames.len() != n_frames * set.frame_len()
            || flows.len() != n_flows * set.flow_len() * 4
        {
            return Err(bad(
                "frames, flows and groups disagree on the cube count or size".into(),
            ));
        }
        set.frames = frames.to_vec();
        set.flows = flows
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        set.groups = groups
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        set.centres = if with_centres {
            let (centres, n_centres) = section("centres", "F32", 4)?;
            if n_centres != n_groups {
                return Err(bad("centres and groups disagree on the cube count".into()));
            }
            centres
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        } else {
            vec![f32::NAN; n_groups]
        };
        if set.flows.iter().any(|v| !v.is_finite()) {
            return Err(bad("flows hold non-finite values".into()));
        }
        Ok(set)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(groups: &[u32]) -> CubeSet {
        let mut s = CubeSet::new(4, 1);
        for (i, &g) in groups.iter().enumerate() {
            let frames: Vec<u8> = (0..s.frame_len()).map(|v| (v + i) as u8).collect();
            let flows: Vec<f32> = (0..s.flow_len())
                .map(|v| v as f32 * 0.5 - i as f32)
                .collect();
            s.push(&frames, &flows, g, 0.1 * i as f32).expect("push");
        }
        s
    }

    #[test]
    fn file_round_trip_is_exact_and_errors_name_the_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("cubes.safetensors");
        let s = set(&[0, 0, 1, 2]);
        s.save(&path).expect("save");
        let back = CubeSet::load(&path).expect("load");
        assert_eq!(back, s);
        assert_eq!(back.centre_of(2), Some(0.2));

        std::fs::write(&path, b"nonsense").expect("write");
        let err = CubeSet::load(&path).expect_err("garbage");
        assert!(err.to_string().contains("cubes.safetensors"), "{err}");
    }

    #[test]
    fn split_keeps_scenarios_apart() {
        let s = set(&[0, 0, 1, 1, 2, 2, 3, 3, 4, 4]);
        let (train, val) = s.split(0.2, 3);
        assert_eq!(train.len() + val.len(), 10);
        assert!(!val.is_empty());
        for v in &val {
            assert!(train.iter().all(|t| s.group_of(*t) != s.group_of(*v)));
        }
        let single = set(&[7; 10]);
        let (train, val) = single.split(0.2, 3);
        assert_eq!(val, vec![8, 9]);
        assert_eq!(train.len(), 8);
    }

    #[test]
    fn wrong_sizes_are_rejected() {
        let mut s = CubeSet::new(4, 1);
        assert!(s.push(&[0; 3], &[0.0; 32], 0, 0.5).is_err());
        assert!(s.push(&[0; 96], &[f32::NAN; 32], 0, 0.5).is_err());
        assert!(s.is_empty());
    }
}
