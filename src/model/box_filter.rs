//! Which object boxes a model scores: [`BoxFilter`], recorded in the model's config so that
//! scoring keeps exactly the boxes training kept.
//!
//! A driving frame shows many vehicles too small or too cut off to say anything about their
//! motion: a 3×3-pixel box resized to a 32×32 patch is a blur, and a parked car sliding out
//! at the image edge moves tens of pixels a frame while only a sliver of it is visible.
//! Those boxes dominate the flow errors without being what an analyst asks about, so the
//! reference drops boxes below a minimum area; the threshold here is a fraction of the frame
//! area, so the same model filters alike at any resolution.

use serde::{Deserialize, Serialize};

use crate::sequence::BoxRecord;

use super::error::ModelError;

/// Which boxes are kept for scoring and training.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoxFilter {
    /// Smallest box area kept, as a fraction of the frame's area (0 keeps every size).
    pub min_area_fraction: f32,
    /// Drop boxes cut by the left, right or bottom edge of the image (a vehicle only partly
    /// in view, usually close and passing).
    pub drop_truncated: bool,
}

impl Default for BoxFilter {
    fn default() -> Self {
        Self::KEEP_ALL
    }
}

/// Distance (pixels) within which a box edge counts as touching the image edge: boxes from
/// instance images end exactly at the border, detector boxes a little inside it.
const EDGE_MARGIN_PX: f32 = 1.0;

impl BoxFilter {
    /// Keeps every box (the reference configuration and every older checkpoint).
    pub const KEEP_ALL: Self = Self {
        min_area_fraction: 0.0,
        drop_truncated: false,
    };

    /// vadscope's filter for its own models: boxes of at least 1/400 of the frame
    /// (≈ 31×31 px at 768×512, the size of a car about 60 m ahead) that lie wholly in the
    /// image.
    pub const DRIVING: Self = Self {
        min_area_fraction: 0.0025,
        drop_truncated: true,
    };

    /// Whether this filter keeps every box.
    pub fn keeps_all(&self) -> bool {
        self.min_area_fraction <= 0.0 && !self.drop_truncated
    }

    /// Whether `b` is kept in a frame of `width` × `height` pixels.
    pub fn keeps(&self, b: &BoxRecord, (width, height): (u32, u32)) -> bool {
        let area = b.width().max(0.0) * b.height().max(0.0);
        if area < self.min_area_fraction * width as f32 * height as f32 {
            return false;
        }
        let truncated = b.x1 <= EDGE_MARGIN_PX
            || b.x2 >= width as f32 - EDGE_MARGIN_PX
            || b.y2 >= height as f32 - EDGE_MARGIN_PX;
        !(self.drop_truncated && truncated)
    }

    /// The boxes of `boxes` this filter keeps, in their order.
    pub fn apply(&self, boxes: Vec<BoxRecord>, frame_size: (u32, u32)) -> Vec<BoxRecord> {
        if self.keeps_all() {
            return boxes;
        }
        boxes
            .into_iter()
            .filter(|b| self.keeps(b, frame_size))
            .collect()
    }

    /// Checks the fraction is a number in [0, 1).
    pub fn validate(&self) -> Result<(), ModelError> {
        if (0.0..1.0).contains(&self.min_area_fraction) {
            Ok(())
        } else {
            Err(ModelError::InvalidConfig(format!(
                "box filter min_area_fraction {} must be in [0, 1)",
                self.min_area_fraction
            )))
        }
    }

    /// A short description for logs and model cards.
    pub fn describe(&self) -> String {
        if self.keeps_all() {
            return "every box".into();
        }
        format!(
            "boxes of at least {:.4} of the frame area{}",
            self.min_area_fraction,
            if self.drop_truncated {
                ", not cut by the image edge"
            } else {
                ""
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::FrameId;

    fn bbox(x1: f32, y1: f32, x2: f32, y2: f32) -> BoxRecord {
        BoxRecord::car(FrameId(0), 1, [x1, y1, x2, y2])
    }

    #[test]
    fn small_boxes_are_dropped_relative_to_the_frame_size() {
        let filter = BoxFilter {
            min_area_fraction: 0.0025,
            drop_truncated: false,
        };
        // 1/400 of 768×512 is 983 px²: 32×32 stays, 30×30 goes.
        assert!(filter.keeps(&bbox(100.0, 100.0, 132.0, 132.0), (768, 512)));
        assert!(!filter.keeps(&bbox(100.0, 100.0, 130.0, 130.0), (768, 512)));
        // At half the resolution half the side is enough.
        assert!(filter.keeps(&bbox(50.0, 50.0, 66.0, 66.0), (384, 256)));
    }

    #[test]
    fn truncated_boxes_are_dropped_only_when_asked() {
        let at_left = bbox(0.0, 100.0, 80.0, 180.0);
        let at_right = bbox(700.0, 100.0, 768.0, 180.0);
        let at_bottom = bbox(300.0, 440.0, 400.0, 512.0);
        let inside = bbox(300.0, 200.0, 400.0, 300.0);
        for b in [&at_left, &at_right, &at_bottom] {
            assert!(!BoxFilter::DRIVING.keeps(b, (768, 512)));
            assert!(BoxFilter::KEEP_ALL.keeps(b, (768, 512)));
        }
        assert!(BoxFilter::DRIVING.keeps(&inside, (768, 512)));
        let kept = BoxFilter::DRIVING.apply(vec![at_left, inside], (768, 512));
        assert_eq!(kept, vec![inside]);
    }

    #[test]
    fn fractions_outside_the_unit_interval_are_rejected() {
        let bad = BoxFilter {
            min_area_fraction: 1.5,
            drop_truncated: false,
        };
        assert!(bad.validate().is_err());
        assert!(BoxFilter::DRIVING.validate().is_ok());
    }
}
