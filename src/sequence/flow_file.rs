//! Dense optical flow fields and their file formats: KITTI 16-bit PNG, Middlebury `.flo`
//! and HF²-VAD `.npy` arrays.
//!
//! A flow stored at frame *i* is the motion from frame *i−1* to frame *i*, in pixels of the
//! frame it was computed on (u right, v down).
//!
//! Formats:
//! - KITTI: 16-bit RGB PNG, channel 1/2 = u/v · 64 + 2¹⁵, channel 3 = valid (0/1); lossless
//!   to 1/64 px within ±512 px.
//! - Middlebury `.flo`: tag "PIEH" (202021.25 as f32), width, height (i32), then interleaved
//!   little-endian f32 (u, v); a component with |value| > 1e9 means unknown.
//! - HF²-VAD `.npy`: a NumPy array of shape (H, W, 2), dtype `<f4`, C order (read only).

use std::path::Path;

use image::{DynamicImage, ExtendedColorType};
use rayon::prelude::*;

use super::SequenceError;
use super::images::read_image;
use super::py_literal::PyValue;

/// A dense 2D displacement field with an optional per-pixel validity flag.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowField {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Interleaved (u, v) per pixel, row-major: `uv[2 * (y * width + x)]` is u.
    pub uv: Vec<f32>,
    /// Per-pixel validity (false where the motion is unknown, e.g. occluded), row-major.
    /// `None` means every pixel is valid.
    pub valid: Option<Vec<bool>>,
}

impl FlowField {
    /// A zero flow of the given size, every pixel valid.
    pub fn zeros(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            uv: vec![0.0; 2 * width as usize * height as usize],
            valid: None,
        }
    }

    /// The (u, v) displacement at pixel (x, y).
    pub fn at(&self, x: u32, y: u32) -> [f32; 2] {
        let i = 2 * (y as usize * self.width as usize + x as usize);
        [self.uv[i], self.uv[i + 1]]
    }

    /// Whether pixel (x, y) carries a known displacement.
    pub fn is_valid(&self, x: u32, y: u32) -> bool {
        self.valid
            .as_ref()
            .is_none_or(|v| v[y as usize * self.width as usize + x as usize])
    }
}

impl FlowField {
    /// Checks that `uv` and `valid` hold one entry per pixel; `path` names the file the
    /// field is about to be written to (or was read from) in the error.
    pub fn check_shape(&self, path: &Path) -> Result<(), SequenceError> {
        let pixels = self.width as usize * self.height as usize;
        if self.uv.len() != 2 * pixels {
            return Err(SequenceError::format(
                path,
                format!(
                    "flow of {}x{} needs {} uv values, has {}",
                    self.width,
                    self.height,
                    2 * pixels,
                    self.uv.len()
                ),
            ));
        }
        if let Some(valid) = &self.valid
            && valid.len() != pixels
        {
            return Err(SequenceError::format(
                path,
                format!(
                    "flow of {}x{} needs {pixels} validity flags, has {}",
                    self.width,
                    self.height,
                    valid.len()
                ),
            ));
        }
        Ok(())
    }

    /// Whether pixel `i` (row-major) is valid and both components are finite.
    #[inline]
    fn is_usable(&self, i: usize) -> bool {
        self.valid.as_ref().is_none_or(|v| v[i])
            && self.uv[2 * i].is_finite()
            && self.uv[2 * i + 1].is_finite()
    }
}

/// Builds a flow field from decoded values, keeping `valid` only when some pixel is invalid.
fn field_from_parts(width: u32, height: u32, uv: Vec<f32>, valid: Vec<bool>) -> FlowField {
    let valid = if valid.iter().all(|&v| v) {
        None
    } else {
        Some(valid)
    };
    FlowField {
        width,
        height,
        uv,
        valid,
    }
}

/// KITTI's offset and scale: stored = value · 64 + 2¹⁵.
const KITTI_OFFSET: f32 = 32768.0;
const KITTI_SCALE: f32 = 64.0;

/// `value · 64 + 2¹⁵` rounded half away from zero and clamped to `u16`. Written out with a
/// truncation instead of `f32::round`, which is a library call on baseline x86-64 and was
/// most of the cost of encoding a flow; the codes are the same.
#[inline]
fn kitti_code(value: f32) -> u16 {
    // Clamped to [-1, 65536] first, so truncation to i32 is exact and so is `x - t`.
    let x = (value * KITTI_SCALE + KITTI_OFFSET).clamp(-1.0, 65536.0);
    let t = x as i32;
    let frac = x - t as f32;
    let rounded = t + i32::from(frac >= 0.5) - i32::from(frac <= -0.5);
    rounded.clamp(0, 65535) as u16
}

/// Encodes a flow as a KITTI 16-bit RGB PNG (fast compression). Invalid or non-finite
/// pixels are stored as zero motion with the valid flag cleared; motion beyond ±512 px
/// is clamped. `path` is only used in error messages.
pub fn encode_kitti_png(path: &Path, flow: &FlowField) -> Result<Vec<u8>, SequenceError> {
    flow.check_shape(path)?;
    let width = flow.width as usize;
    let mut bytes = vec![0u8; 6 * width * flow.height as usize];
    let unknown = [kitti_code(0.0), kitti_code(0.0), 0];
    let row_len = width.max(1);
    // Row by row over fixed-size pixel chunks, so that no access needs a bounds check.
    bytes
        .par_chunks_mut(6 * row_len)
        .zip(flow.uv.par_chunks(2 * row_len))
        .enumerate()
        .for_each(|(y, (row, uv_row))| {
            let valid = flow
                .valid
                .as_deref()
                .map(|v| &v[y * width..(y + 1) * width]);
            let pixels = row.as_chunks_mut::<6>().0.iter_mut();
            for (x, (px, &[u, v])) in pixels.zip(uv_row.as_chunks::<2>().0).enumerate() {
                let usable = valid.is_none_or(|valid| valid[x]) && u.is_finite() && v.is_finite();
                let channels = if usable {
                    [kitti_code(u), kitti_code(v), 1]
                } else {
                    unknown
                };
                for (out, channel) in px.as_chunks_mut::<2>().0.iter_mut().zip(channels) {
                    *out = channel.to_ne_bytes();
                }
            }
        });
    super::images::encode_png(
        path,
        &bytes,
        flow.width,
        flow.height,
        ExtendedColorType::Rgb16,
    )
}

/// Writes a flow as a KITTI 16-bit RGB PNG.
pub fn write_kitti_png(path: &Path, flow: &FlowField) -> Result<(), SequenceError> {
    let bytes = encode_kitti_png(path, flow)?;
    std::fs::write(path, bytes).map_err(|e| SequenceError::io(path, e))
}

/// Reads a KITTI 16-bit RGB flow PNG. Pixels with a zero valid channel are invalid and
/// read as zero motion.
pub fn read_kitti_png(path: &Path) -> Result<FlowField, SequenceError> {
    let rgb16 = match read_image(path)? {
        DynamicImage::ImageRgb16(rgb16) => rgb16,
        other => {
            return Err(SequenceError::format(
                path,
                format!(
                    "KITTI flow PNG must be 16-bit RGB, found {:?}",
                    other.color()
                ),
            ));
        }
    };
    let (width, height) = rgb16.dimensions();
    let pixels = width as usize * height as usize;
    let mut uv = Vec::with_capacity(2 * pixels);
    let mut valid = Vec::with_capacity(pixels);
    for pixel in rgb16.pixels() {
        let [u, v, flag] = pixel.0;
        if flag == 0 {
            uv.extend([0.0, 0.0]);
        } else {
            uv.push((f32::from(u) - KITTI_OFFSET) / KITTI_SCALE);
            uv.push((f32::from(v) - KITTI_OFFSET) / KITTI_SCALE);
        }
        valid.push(flag != 0);
    }
    Ok(field_from_parts(width, height, uv, valid))
}

/// The `.flo` tag: the bytes "PIEH", which read as a little-endian f32 are 202021.25.
const FLO_TAG: [u8; 4] = *b"PIEH";
const FLO_HEADER_BYTES: usize = 12;
/// Components beyond this magnitude mean "unknown" in `.flo` files.
const FLO_UNKNOWN_THRESHOLD: f32 = 1e9;
/// What we write for unknown components (the Middlebury convention).
const FLO_UNKNOWN_VALUE: f32 = 1e10;
/// Largest side accepted when reading, so a corrupt header cannot request a huge buffer.
const MAX_FLOW_SIDE: u32 = 1 << 15;

/// Encodes a flow as Middlebury `.flo` bytes; invalid pixels are written as 1e10.
pub fn encode_flo(path: &Path, flow: &FlowField) -> Result<Vec<u8>, SequenceError> {
    flow.check_shape(path)?;
    let width = i32::try_from(flow.width)
        .map_err(|_| SequenceError::format(path, "flow too wide for .flo"))?;
    let height = i32::try_from(flow.height)
        .map_err(|_| SequenceError::format(path, "flow too tall for .flo"))?;
    let pixels = flow.width as usize * flow.height as usize;
    let mut bytes = Vec::with_capacity(FLO_HEADER_BYTES + 8 * pixels);
    bytes.extend_from_slice(&FLO_TAG);
    bytes.extend_from_slice(&width.to_le_bytes());
    bytes.extend_from_slice(&height.to_le_bytes());
    for i in 0..pixels {
        let (u, v) = if flow.is_usable(i) {
            (flow.uv[2 * i], flow.uv[2 * i + 1])
        } else {
            (FLO_UNKNOWN_VALUE, FLO_UNKNOWN_VALUE)
        };
        bytes.extend_from_slice(&u.to_le_bytes());
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    Ok(bytes)
}

/// Writes a flow as a Middlebury `.flo` file.
pub fn write_flo(path: &Path, flow: &FlowField) -> Result<(), SequenceError> {
    let bytes = encode_flo(path, flow)?;
    std::fs::write(path, bytes).map_err(|e| SequenceError::io(path, e))
}

/// Reads a Middlebury `.flo` file. Components with |value| > 1e9 (or NaN) make the pixel
/// invalid; invalid pixels read as zero motion.
pub fn read_flo(path: &Path) -> Result<FlowField, SequenceError> {
    let bytes = std::fs::read(path).map_err(|e| SequenceError::io(path, e))?;
    decode_flo(path, &bytes)
}

/// Checks the 12-byte `.flo` header (length, tag, plausible size); returns (width, height).
fn parse_flo_header(path: &Path, bytes: &[u8]) -> Result<(u32, u32), SequenceError> {
    let Some(header) = bytes.first_chunk::<FLO_HEADER_BYTES>() else {
        return Err(SequenceError::format(
            path,
            format!(
                "truncated .flo: the header needs {FLO_HEADER_BYTES} bytes, the file has {}",
                bytes.len()
            ),
        ));
    };
    let tag = [header[0], header[1], header[2], header[3]];
    if tag != FLO_TAG {
        return Err(SequenceError::format(
            path,
            format!(
                "not a .flo file: tag is {tag:?} ({}), expected \"PIEH\" (202021.25)",
                f32::from_le_bytes(tag)
            ),
        ));
    }
    let width = i32::from_le_bytes([header[4], header[5], header[6], header[7]]);
    let height = i32::from_le_bytes([header[8], header[9], header[10], header[11]]);
    checked_size(path, i64::from(width), i64::from(height))
}

/// Decodes `.flo` bytes; `path` is only used in error messages.
pub fn decode_flo(path: &Path, bytes: &[u8]) -> Result<FlowField, SequenceError> {
    let (width, height) = parse_flo_header(path, bytes)?;
    let data = bytes.get(FLO_HEADER_BYTES..).unwrap_or_default();
    let pixels = width as usize * height as usize;
    if data.len() != 8 * pixels {
        return Err(SequenceError::format(
            path,
            format!(
                "truncated or padded .flo: {width}x{height} needs {} data bytes, found {}",
                8 * pixels,
                data.len()
            ),
        ));
    }
    let mut uv = Vec::with_capacity(2 * pixels);
    let mut valid = Vec::with_capacity(pixels);
    for pair in data.chunks_exact(8) {
        let u = f32::from_le_bytes([pair[0], pair[1], pair[2], pair[3]]);
        let v = f32::from_le_bytes([pair[4], pair[5], pair[6], pair[7]]);
        let known = |c: f32| c.abs() <= FLO_UNKNOWN_THRESHOLD;
        if known(u) && known(v) {
            uv.extend([u, v]);
            valid.push(true);
        } else {
            uv.extend([0.0, 0.0]);
            valid.push(false);
        }
    }
    Ok(field_from_parts(width, height, uv, valid))
}

fn checked_size(path: &Path, width: i64, height: i64) -> Result<(u32, u32), SequenceError> {
    let side_ok = |s: i64| (1..=i64::from(MAX_FLOW_SIDE)).contains(&s);
    if side_ok(width) && side_ok(height) {
        Ok((width as u32, height as u32))
    } else {
        Err(SequenceError::format(
            path,
            format!(
                "implausible flow size {width}x{height} (each side must be 1..={MAX_FLOW_SIDE})"
            ),
        ))
    }
}

const NPY_MAGIC: &[u8; 6] = b"\x93NUMPY";

/// Reads an HF²-VAD flow array: `.npy`, shape (H, W, 2), dtype `<f4`, C order.
/// Non-finite values make the pixel invalid.
pub fn read_npy(path: &Path) -> Result<FlowField, SequenceError> {
    let bytes = std::fs::read(path).map_err(|e| SequenceError::io(path, e))?;
    decode_npy(path, &bytes)
}

/// Decodes `.npy` flow bytes; `path` is only used in error messages.
pub fn decode_npy(path: &Path, bytes: &[u8]) -> Result<FlowField, SequenceError> {
    let (header, data) = split_npy_header(path, bytes)?;
    let (height, width) = npy_flow_shape(path, header)?;
    let pixels = width as usize * height as usize;
    if data.len() != 8 * pixels {
        return Err(SequenceError::format(
            path,
            format!(
                "npy data has {} bytes, shape ({height}, {width}, 2) float32 needs {}",
                data.len(),
                8 * pixels
            ),
        ));
    }
    let mut uv = Vec::with_capacity(2 * pixels);
    let mut valid = Vec::with_capacity(pixels);
    for pair in data.chunks_exact(8) {
        let u = f32::from_le_bytes([pair[0], pair[1], pair[2], pair[3]]);
        let v = f32::from_le_bytes([pair[4], pair[5], pair[6], pair[7]]);
        let finite = u.is_finite() && v.is_finite();
        uv.extend(if finite { [u, v] } else { [0.0, 0.0] });
        valid.push(finite);
    }
    Ok(field_from_parts(width, height, uv, valid))
}

/// Splits an `.npy` file into its header text and data bytes (format versions 1, 2 and 3).
fn split_npy_header<'a>(
    path: &Path,
    bytes: &'a [u8],
) -> Result<(&'a str, &'a [u8]), SequenceError> {
    let bad = |problem: String| SequenceError::format(path, problem);
    if bytes.len() < 10 || &bytes[..6] != NPY_MAGIC {
        return Err(bad("not an .npy file: missing the \\x93NUMPY magic".into()));
    }
    let (length_bytes, header_start) = match bytes[6] {
        1 => (2, 10),
        2 | 3 => (4, 12),
        major => {
            return Err(bad(format!(
                "unsupported .npy format version {major}.{}",
                bytes[7]
            )));
        }
    };
    let Some(length_field) = bytes.get(8..8 + length_bytes) else {
        return Err(bad("truncated .npy header length".into()));
    };
    let header_len = length_field
        .iter()
        .rev()
        .fold(0usize, |acc, &b| (acc << 8) | usize::from(b));
    let Some(header) = bytes.get(header_start..header_start + header_len) else {
        return Err(bad(format!(
            "truncated .npy: header of {header_len} bytes runs past the end of the file ({} bytes)",
            bytes.len()
        )));
    };
    let text = std::str::from_utf8(header).map_err(|_| bad("npy header is not text".into()))?;
    Ok((text, &bytes[header_start + header_len..]))
}

/// Checks the header dict and returns (height, width) of an (H, W, 2) float32 array.
fn npy_flow_shape(path: &Path, header: &str) -> Result<(u32, u32), SequenceError> {
    let bad = |problem: String| SequenceError::format(path, problem);
    let dict = PyValue::parse(header).map_err(|e| bad(format!("npy header is not a dict: {e}")))?;
    match dict.get("descr") {
        Some(PyValue::Str(descr)) if descr == "<f4" => {}
        Some(PyValue::Str(descr)) => {
            return Err(bad(format!(
                "npy dtype '{descr}' is not little-endian float32 '<f4'"
            )));
        }
        _ => return Err(bad("npy header has no 'descr' string".into())),
    }
    match dict.get("fortran_order") {
        Some(PyValue::Bool(false)) => {}
        Some(PyValue::Bool(true)) => {
            return Err(bad(
                "npy array is in Fortran order; only C order is supported".into(),
            ));
        }
        _ => return Err(bad("npy header has no 'fortran_order' flag".into())),
    }
    let shape = dict
        .get("shape")
        .and_then(PyValue::as_numbers)
        .ok_or_else(|| bad("npy header has no 'shape' tuple".into()))?;
    match shape.as_slice() {
        [h, w, c] if *c == 2.0 && h.fract() == 0.0 && w.fract() == 0.0 => {
            let (w, h) = checked_size(path, *w as i64, *h as i64)?;
            Ok((h, w))
        }
        _ => Err(bad(format!(
            "npy shape {shape:?} is not (height, width, 2)"
        ))),
    }
}

/// Checks a flow file's header and size without decoding its values; returns (width,
/// height). Used by validation, which must stay fast on long scenarios.
pub fn probe_flow(path: &Path) -> Result<(u32, u32), SequenceError> {
    use std::io::Read;
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let file_len = std::fs::metadata(path)
        .map_err(|e| SequenceError::io(path, e))?
        .len();
    let read_prefix = |limit: u64| -> Result<Vec<u8>, SequenceError> {
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(limit).read_to_end(&mut bytes))
            .map_err(|e| SequenceError::io(path, e))?;
        Ok(bytes)
    };
    match extension.as_deref() {
        Some("png") => {
            let header = super::images::read_header(path)?;
            if header.color != super::images::ColorLayout::Rgb16 {
                return Err(SequenceError::format(
                    path,
                    format!(
                        "KITTI flow PNG must be 16-bit RGB, found {:?}",
                        header.color
                    ),
                ));
            }
            Ok((header.width, header.height))
        }
        Some("flo") => {
            let (width, height) = parse_flo_header(path, &read_prefix(FLO_HEADER_BYTES as u64)?)?;
            let needed = (FLO_HEADER_BYTES + 8 * width as usize * height as usize) as u64;
            if file_len != needed {
                return Err(SequenceError::format(
                    path,
                    format!(
                        "truncated or padded .flo: {width}x{height} needs {needed} bytes, the file has {file_len}"
                    ),
                ));
            }
            Ok((width, height))
        }
        Some("npy") => {
            let bytes = read_prefix(1 << 16)?;
            let (header, data) = split_npy_header(path, &bytes)?;
            let (height, width) = npy_flow_shape(path, header)?;
            let data_len = file_len - (bytes.len() - data.len()) as u64;
            let needed = 8 * u64::from(width) * u64::from(height);
            if data_len != needed {
                return Err(SequenceError::format(
                    path,
                    format!(
                        "npy data has {data_len} bytes, shape ({height}, {width}, 2) float32 needs {needed}"
                    ),
                ));
            }
            Ok((width, height))
        }
        _ => Err(SequenceError::format(
            path,
            "unknown flow file type (expected .png, .flo or .npy)",
        )),
    }
}

/// Reads a flow file, choosing the format by extension: `.png` (KITTI), `.flo`, `.npy`.
pub fn read_flow(path: &Path) -> Result<FlowField, SequenceError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("png") => read_kitti_png(path),
        Some("flo") => read_flo(path),
        Some("npy") => read_npy(path),
        _ => Err(SequenceError::format(
            path,
            "unknown flow file type (expected .png, .flo or .npy)",
        )),
    }
}

/// Writes `flow` as KITTI PNG or `.flo`, chosen by the extension of `path`.
pub fn write_flow(path: &Path, flow: &FlowField) -> Result<(), SequenceError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("png") => write_kitti_png(path, flow),
        Some("flo") => write_flo(path, flow),
        _ => Err(SequenceError::format(
            path,
            "flow can be written as .png (KITTI) or .flo only",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_flow() -> FlowField {
        let (width, height) = (5, 3);
        let uv = (0..2 * width * height)
            .map(|i| (i as f32 - 12.0) * 1.25 + 0.015625)
            .collect();
        FlowField {
            width: width as u32,
            height: height as u32,
            uv,
            valid: None,
        }
    }

    #[test]
    fn kitti_codes_are_value_times_64_plus_offset() {
        assert_eq!(kitti_code(0.0), 32768);
        assert_eq!(kitti_code(1.0), 32832);
        assert_eq!(kitti_code(-0.5), 32736);
        assert_eq!(kitti_code(1e6), 65535);
        assert_eq!(kitti_code(-1e6), 0);
    }

    #[test]
    fn kitti_codes_round_like_f32_round() {
        let reference =
            |v: f32| (v * KITTI_SCALE + KITTI_OFFSET).round().clamp(0.0, 65535.0) as u16;
        // Every half step (ties), the values either side of them, the clamping range's
        // edges and the non-finite values.
        let mut values = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0];
        for k in -8i32..131_100 {
            let tie = (k as f32 * 0.5 - KITTI_OFFSET) / KITTI_SCALE;
            values.extend([tie, tie.next_up(), tie.next_down()]);
        }
        for v in values {
            assert_eq!(kitti_code(v), reference(v), "{v:e}");
        }
    }

    #[test]
    fn flo_bytes_round_trip_with_unknown_pixels() {
        let mut flow = sample_flow();
        let mut valid = vec![true; 15];
        valid[7] = false;
        flow.valid = Some(valid.clone());
        let path = Path::new("mem.flo");
        let bytes = encode_flo(path, &flow).expect("encodes");
        assert_eq!(bytes.len(), 12 + 8 * 15);
        assert_eq!(
            f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
            202021.25
        );
        let back = decode_flo(path, &bytes).expect("decodes");
        assert_eq!(back.valid, Some(valid));
        assert_eq!(back.at(2, 1), [0.0, 0.0]);
        assert_eq!(back.at(4, 2), flow.at(4, 2));
    }

    #[test]
    fn check_shape_rejects_inconsistent_fields() {
        let mut flow = sample_flow();
        flow.uv.pop();
        let error = encode_flo(Path::new("x.flo"), &flow).expect_err("short uv");
        assert!(error.to_string().contains("x.flo"), "{error}");
        let mut flow = sample_flow();
        flow.valid = Some(vec![true; 3]);
        assert!(flow.check_shape(Path::new("y.png")).is_err());
    }
}
