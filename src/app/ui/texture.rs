//! A texture that follows an image: it is redrawn and uploaded only when the key of what
//! it shows changes (frame, view, settings, size), so an idle viewer uploads nothing.

use egui::{ColorImage, TextureHandle, TextureOptions};
use image::RgbaImage;

/// One texture and the key of the image it holds.
pub struct CachedTexture<K> {
    name: &'static str,
    key: Option<K>,
    handle: Option<TextureHandle>,
}

impl<K: PartialEq> CachedTexture<K> {
    /// An empty texture named `name` (for egui's debugging).
    pub fn new(name: &'static str) -> Self {
        Self {
            name,
            key: None,
            handle: None,
        }
    }

    /// The texture for `key`: the held one when the key is unchanged, else `draw()`
    /// uploaded (a `None` from `draw` clears it).
    pub fn get(
        &mut self,
        ctx: &egui::Context,
        key: K,
        draw: impl FnOnce() -> Option<RgbaImage>,
    ) -> Option<&TextureHandle> {
        if self.key.as_ref() != Some(&key) {
            match draw() {
                Some(image) => {
                    let color = to_color_image(&image);
                    match &mut self.handle {
                        Some(handle) => handle.set(color, TextureOptions::LINEAR),
                        None => {
                            self.handle =
                                Some(ctx.load_texture(self.name, color, TextureOptions::LINEAR));
                        }
                    }
                }
                None => self.handle = None,
            }
            self.key = Some(key);
        }
        self.handle.as_ref()
    }
}

/// An RGBA image as egui's image type.
pub fn to_color_image(image: &RgbaImage) -> ColorImage {
    ColorImage::from_rgba_unmultiplied(
        [image.width() as usize, image.height() as usize],
        image.as_raw(),
    )
}
