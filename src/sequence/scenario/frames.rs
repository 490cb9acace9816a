//! Frame access of a [`Scenario`]: each modality's file of a frame decoded through the
//! scenario's byte-bounded LRU cache, its size checked against the scenario's frames, and
//! the cache's budget and release.

use std::path::Path;
use std::sync::Arc;

use image::{GrayImage, RgbImage};

use super::super::depth::DepthMap;
use super::super::flow_file::read_flow;
use super::super::images::{
    InstanceImage, SemanticImage, read_depth, read_instance, read_rgb, read_semantic,
};
use super::super::keyvalue::read_key_values;
use super::super::{FlowField, FrameId, KeyValues, Modality, SequenceError, palette};
use super::Scenario;

/// Which decoded product a cache entry holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Slot {
    Rgb,
    Semantic,
    Instance,
    Depth,
    Mask,
    Flow,
}

/// A decoded product in the cache.
#[derive(Debug, Clone)]
pub(super) enum Decoded {
    Rgb(Arc<RgbImage>),
    Semantic(Arc<SemanticImage>),
    Instance(Arc<InstanceImage>),
    Depth(Arc<DepthMap>),
    Mask(Arc<GrayImage>),
    Flow(Arc<FlowField>),
}

/// A type that can live in the frame cache.
trait Cacheable: Sized {
    fn wrap(value: Arc<Self>) -> Decoded;
    fn unwrap(decoded: Decoded) -> Option<Arc<Self>>;
    fn bytes(&self) -> usize;
}

macro_rules! cacheable {
    ($type:ty, $variant:ident, |$value:ident| $bytes:expr) => {
        impl Cacheable for $type {
            fn wrap(value: Arc<Self>) -> Decoded {
                Decoded::$variant(value)
            }
            fn unwrap(decoded: Decoded) -> Option<Arc<Self>> {
                match decoded {
                    Decoded::$variant(value) => Some(value),
                    _ => None,
                }
            }
            fn bytes(&self) -> usize {
                let $value = self;
                $bytes
            }
        }
    };
}

cacheable!(RgbImage, Rgb, |image| image.as_raw().len());
cacheable!(SemanticImage, Semantic, |image| image.ids.as_raw().len());
cacheable!(InstanceImage, Instance, |image| 3 * image.tags.len());
cacheable!(DepthMap, Depth, |depth| 4 * depth.as_raw().len());
cacheable!(GrayImage, Mask, |mask| mask.as_raw().len());
cacheable!(FlowField, Flow, |flow| 4 * flow.uv.len()
    + flow.valid.as_ref().map_or(0, Vec::len));

impl Scenario {
    pub(super) fn frame_id_checked(&self, index: usize) -> Result<FrameId, SequenceError> {
        self.index.frame_id(index).ok_or_else(|| {
            SequenceError::format(
                &self.root,
                format!(
                    "frame index {index} is out of range (the scenario has {} frames)",
                    self.len()
                ),
            )
        })
    }

    /// The file of `modality` for frame `index`; an error when the index is out of range.
    fn file_checked(
        &self,
        modality: Modality,
        index: usize,
    ) -> Result<Option<&Path>, SequenceError> {
        let id = self.frame_id_checked(index)?;
        Ok(self.files.file(modality, id))
    }

    fn check_size(&self, path: &Path, width: u32, height: u32) -> Result<(), SequenceError> {
        let (w, h) = self.resolution;
        if (width, height) == (w, h) {
            Ok(())
        } else {
            Err(SequenceError::format(
                path,
                format!("image is {width}x{height} but the scenario's frames are {w}x{h}"),
            ))
        }
    }

    /// Decodes through the cache.
    fn cached<T: Cacheable>(
        &self,
        slot: Slot,
        index: usize,
        load: impl FnOnce() -> Result<T, SequenceError>,
    ) -> Result<Arc<T>, SequenceError> {
        if let Some(value) = self.cache.get(&(slot, index)).and_then(T::unwrap) {
            return Ok(value);
        }
        let value = Arc::new(load()?);
        self.cache
            .insert((slot, index), T::wrap(value.clone()), value.bytes());
        Ok(value)
    }

    /// The camera frame `index` as 8-bit RGB.
    pub fn rgb(&self, index: usize) -> Result<Arc<RgbImage>, SequenceError> {
        let path = self.file_checked(Modality::Rgb, index)?.ok_or_else(|| {
            SequenceError::format(&self.root, format!("frame index {index} has no RGB file"))
        })?;
        self.cached(Slot::Rgb, index, || {
            let image = read_rgb(path)?;
            self.check_size(path, image.width(), image.height())?;
            Ok(image)
        })
    }

    /// The semantic image of frame `index` as class ids (L files as stored, palette files
    /// mapped back to ids).
    pub fn semantic(&self, index: usize) -> Result<Option<Arc<SemanticImage>>, SequenceError> {
        let Some(path) = self.file_checked(Modality::Semantic, index)? else {
            return Ok(None);
        };
        self.cached(Slot::Semantic, index, || {
            let image = read_semantic(path)?;
            self.check_size(path, image.ids.width(), image.ids.height())?;
            Ok(image)
        })
        .map(Some)
    }

    /// The instance image of frame `index` (tag and id = G + 256·B per pixel).
    pub fn instance(&self, index: usize) -> Result<Option<Arc<InstanceImage>>, SequenceError> {
        let Some(path) = self.file_checked(Modality::Instance, index)? else {
            return Ok(None);
        };
        self.cached(Slot::Instance, index, || {
            let image = read_instance(path)?;
            self.check_size(path, image.width, image.height)?;
            Ok(image)
        })
        .map(Some)
    }

    /// The depth of frame `index` in metres.
    pub fn depth_m(&self, index: usize) -> Result<Option<Arc<DepthMap>>, SequenceError> {
        let Some(path) = self.file_checked(Modality::Depth, index)? else {
            return Ok(None);
        };
        self.cached(Slot::Depth, index, || {
            let depth = read_depth(path)?;
            self.check_size(path, depth.width(), depth.height())?;
            Ok(depth)
        })
        .map(Some)
    }

    /// The pixel anomaly mask of frame `index` (255 = anomaly): semantic ids 100 and 29–34,
    /// which also covers the palette colours (245, 0, 0) and (245, k, 0).
    pub fn anomaly_mask(&self, index: usize) -> Result<Option<Arc<GrayImage>>, SequenceError> {
        let Some(semantic) = self.semantic(index)? else {
            return Ok(None);
        };
        self.cached(Slot::Mask, index, || {
            let mut mask = semantic.ids.clone();
            for pixel in mask.pixels_mut() {
                pixel.0[0] = if palette::is_anomaly_id(pixel.0[0]) {
                    255
                } else {
                    0
                };
            }
            Ok(mask)
        })
        .map(Some)
    }

    /// The stored flow into frame `index` (from frame `index − 1`), if any: see
    /// [`super::discovery`] for where flows are looked up.
    pub fn flow(&self, index: usize) -> Result<Option<Arc<FlowField>>, SequenceError> {
        let Some(path) = self.file_checked(Modality::Flow, index)? else {
            return Ok(None);
        };
        self.cached(Slot::Flow, index, || {
            let flow = read_flow(path)?;
            self.check_size(path, flow.width, flow.height)?;
            Ok(flow)
        })
        .map(Some)
    }

    /// The ego state (ACTION csv) of frame `index`.
    pub fn action(&self, index: usize) -> Result<Option<KeyValues>, SequenceError> {
        self.file_checked(Modality::Action, index)?
            .map(read_key_values)
            .transpose()
    }

    /// The anomaly actor's state (ANOMALY csv) of frame `index`.
    pub fn anomaly_state(&self, index: usize) -> Result<Option<KeyValues>, SequenceError> {
        self.file_checked(Modality::Anomaly, index)?
            .map(read_key_values)
            .transpose()
    }

    /// Bytes held by the decoded-frame cache.
    pub fn cache_bytes(&self) -> usize {
        self.cache.bytes_used()
    }

    /// Entries held by the decoded-frame cache.
    pub fn cache_entries(&self) -> usize {
        self.cache.len()
    }

    /// The decoded-frame cache's byte budget.
    pub fn cache_budget(&self) -> usize {
        self.cache.budget()
    }

    /// Drops every decoded frame the cache holds. Commands that go through many scenarios
    /// call it when they are done with one, so their memory stays flat in the number of
    /// scenarios (each scenario's cache may otherwise keep up to its whole budget).
    pub fn release_decoded(&self) {
        self.cache.clear();
    }

    /// Changes the decoded-frame cache's byte budget (evicting at once when lowered).
    pub fn set_cache_budget(&self, bytes: usize) {
        self.cache.set_budget(bytes);
    }
}
