//! PNG encoding and decoding for the image modalities: RGB frames, semantic class images
//! (L ids or palette colours), instance images, CARLA depth, plus header-only probing for
//! validation.
//!
//! Encoding uses the PNG encoder's fast deflate level, because the generator writes five
//! PNGs per frame and must keep up with real time; the files are still lossless.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use image::codecs::png::{CompressionType, FilterType, PngDecoder, PngEncoder};
use image::{
    DynamicImage, ExtendedColorType, GrayImage, ImageDecoder, ImageEncoder, ImageFormat,
    ImageReader, RgbImage,
};
use serde::Serialize;

use super::SequenceError;
use super::depth::{DepthMap, decode_depth_image};
use super::palette;

/// Filter used for every PNG we write. With the fast compressor, which codes runs of zero
/// bytes cheaply, `Paeth` is the quickest in all (it leaves the most zeros, which more than
/// pays for its own cost) and the smallest: on generated 768×512 frames it encodes a 16-bit
/// flow in 70–90 % and a depth image in 45–70 % of the time `Up` takes, at 60 % and 15 % of
/// the size, and RGB about as fast at 75 % of the size. The adaptive heuristic tries all five
/// filters per row and is slower.
const PNG_FILTER: FilterType = FilterType::Paeth;

/// Encodes raw pixel bytes as a PNG with fast compression. 16-bit layouts take native-endian
/// bytes, as `image`'s encoder expects.
pub fn encode_png(
    path: &Path,
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<Vec<u8>, SequenceError> {
    let expected =
        u64::from(color.bits_per_pixel()).div_ceil(8) * u64::from(width) * u64::from(height);
    if pixels.len() as u64 != expected {
        return Err(SequenceError::format(
            path,
            format!(
                "pixel buffer holds {} bytes, a {width}x{height} {color:?} image needs {expected}",
                pixels.len()
            ),
        ));
    }
    let mut bytes = Vec::with_capacity(pixels.len() / 2);
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, PNG_FILTER)
        .write_image(pixels, width, height, color)
        .map_err(|e| SequenceError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    Ok(bytes)
}

/// Encodes raw pixel bytes as a fast PNG and writes it to `path`.
pub fn write_png(
    path: &Path,
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<(), SequenceError> {
    let bytes = encode_png(path, pixels, width, height, color)?;
    std::fs::write(path, bytes).map_err(|e| SequenceError::io(path, e))
}

/// Decodes any supported image file into a [`DynamicImage`].
pub fn read_image(path: &Path) -> Result<DynamicImage, SequenceError> {
    let reader = ImageReader::open(path)
        .map_err(|e| SequenceError::io(path, e))?
        .with_guessed_format()
        .map_err(|e| SequenceError::io(path, e))?;
    reader.decode().map_err(|e| SequenceError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Size and pixel layout of an image file, read from its header only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ImageHeader {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixel layout, e.g. `Rgb8`, `L8`, `Rgb16`.
    pub color: ColorLayout,
}

/// The pixel layouts that matter to scenario files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ColorLayout {
    /// 8-bit grey (class ids).
    L8,
    /// 8-bit RGB.
    Rgb8,
    /// 8-bit RGBA.
    Rgba8,
    /// 16-bit RGB (KITTI flow).
    Rgb16,
    /// Anything else (16-bit grey, grey+alpha, ...).
    Other,
}

impl ColorLayout {
    fn of(color: image::ColorType) -> Self {
        match color {
            image::ColorType::L8 => ColorLayout::L8,
            image::ColorType::Rgb8 => ColorLayout::Rgb8,
            image::ColorType::Rgba8 => ColorLayout::Rgba8,
            image::ColorType::Rgb16 => ColorLayout::Rgb16,
            _ => ColorLayout::Other,
        }
    }
}

/// Reads only the header of an image file: fast enough to probe every frame of a scenario.
pub fn read_header(path: &Path) -> Result<ImageHeader, SequenceError> {
    let decode_error = |e: image::ImageError| SequenceError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let file = File::open(path).map_err(|e| SequenceError::io(path, e))?;
    let reader = BufReader::new(file);
    let format = ImageFormat::from_path(path).unwrap_or(ImageFormat::Png);
    if format != ImageFormat::Png {
        let image = read_image(path)?;
        return Ok(ImageHeader {
            width: image.width(),
            height: image.height(),
            color: ColorLayout::of(image.color()),
        });
    }
    let decoder = PngDecoder::new(reader).map_err(decode_error)?;
    let (width, height) = decoder.dimensions();
    Ok(ImageHeader {
        width,
        height,
        color: ColorLayout::of(decoder.color_type()),
    })
}

/// Reads a camera frame as 8-bit RGB (alpha dropped, grey expanded, 16-bit reduced).
pub fn read_rgb(path: &Path) -> Result<RgbImage, SequenceError> {
    Ok(match read_image(path)? {
        DynamicImage::ImageRgb8(rgb) => rgb,
        other => other.to_rgb8(),
    })
}

/// How a semantic image stored its classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum SemanticEncoding {
    /// Single-channel PNG, pixel value = AnoVox class id (generator convention).
    ClassIds,
    /// RGB(A) PNG in the CityScapes/AnoVox palette (benchmark convention).
    Palette,
}

/// A semantic image decoded to class ids, with the encoding it was stored in.
#[derive(Debug, Clone, PartialEq)]
pub struct SemanticImage {
    /// AnoVox class id per pixel (colours not in the palette read as 0, unlabeled).
    pub ids: GrayImage,
    /// The file's encoding.
    pub encoding: SemanticEncoding,
}

/// Reads a semantic image: L PNGs are taken as class ids, RGB(A) PNGs are mapped back
/// from palette colours to ids.
pub fn read_semantic(path: &Path) -> Result<SemanticImage, SequenceError> {
    match read_image(path)? {
        DynamicImage::ImageLuma8(ids) => Ok(SemanticImage {
            ids,
            encoding: SemanticEncoding::ClassIds,
        }),
        DynamicImage::ImageRgb8(rgb) => Ok(palette_to_ids(&rgb)),
        DynamicImage::ImageRgba8(rgba) => {
            Ok(palette_to_ids(&DynamicImage::ImageRgba8(rgba).to_rgb8()))
        }
        other => Err(SequenceError::format(
            path,
            format!(
                "semantic image must be 8-bit grey (class ids) or 8-bit RGB (palette), found {:?}",
                other.color()
            ),
        )),
    }
}

fn palette_to_ids(rgb: &RgbImage) -> SemanticImage {
    let ids = GrayImage::from_fn(rgb.width(), rgb.height(), |x, y| {
        image::Luma([palette::id_of_colour(rgb.get_pixel(x, y).0).unwrap_or(0)])
    });
    SemanticImage {
        ids,
        encoding: SemanticEncoding::Palette,
    }
}

/// An instance image: CARLA tag and instance id per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Semantic tag per pixel (the red channel), row-major.
    pub tags: Vec<u8>,
    /// Instance id per pixel (G + 256·B), row-major.
    pub ids: Vec<u16>,
}

impl InstanceImage {
    /// Splits an RGB instance image into tags and ids.
    pub fn from_rgb(rgb: &RgbImage) -> Self {
        let (tags, ids) = rgb
            .pixels()
            .map(|p| (p.0[0], u16::from(p.0[1]) | (u16::from(p.0[2]) << 8)))
            .unzip();
        Self {
            width: rgb.width(),
            height: rgb.height(),
            tags,
            ids,
        }
    }

    /// Packs tags and ids back into the RGB encoding.
    pub fn to_rgb(&self) -> RgbImage {
        let bytes = self
            .tags
            .iter()
            .zip(&self.ids)
            .flat_map(|(&tag, &id)| [tag, (id & 0xff) as u8, (id >> 8) as u8])
            .collect();
        RgbImage::from_raw(self.width, self.height, bytes)
            .expect("one tag and one id per pixel of the instance image")
    }
}

/// Reads an instance image (R = tag, G + 256·B = id).
pub fn read_instance(path: &Path) -> Result<InstanceImage, SequenceError> {
    match read_image(path)? {
        DynamicImage::ImageRgb8(rgb) => Ok(InstanceImage::from_rgb(&rgb)),
        DynamicImage::ImageRgba8(rgba) => Ok(InstanceImage::from_rgb(
            &DynamicImage::ImageRgba8(rgba).to_rgb8(),
        )),
        other => Err(SequenceError::format(
            path,
            format!(
                "instance image must be 8-bit RGB (R = tag, G + 256*B = id), found {:?}",
                other.color()
            ),
        )),
    }
}

/// Reads a CARLA raw depth PNG into metres.
pub fn read_depth(path: &Path) -> Result<DepthMap, SequenceError> {
    match read_image(path)? {
        DynamicImage::ImageRgb8(rgb) => Ok(decode_depth_image(&rgb)),
        DynamicImage::ImageRgba8(rgba) => Ok(decode_depth_image(
            &DynamicImage::ImageRgba8(rgba).to_rgb8(),
        )),
        other => Err(SequenceError::format(
            path,
            format!(
                "depth image must be 8-bit RGB (CARLA 24-bit depth), found {:?}",
                other.color()
            ),
        )),
    }
}
