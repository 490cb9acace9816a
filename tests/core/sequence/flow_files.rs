//! Flow file formats on disk: KITTI 16-bit PNG, Middlebury `.flo`, HF²-VAD `.npy`, and the
//! errors for malformed files (each must name the file and the problem).

use std::path::Path;

use vadscope::sequence::FlowField;
use vadscope::sequence::flow_file::{
    read_flo, read_flow, read_kitti_png, read_npy, write_flo, write_flow, write_kitti_png,
};

fn ramp_flow(width: u32, height: u32) -> FlowField {
    let uv = (0..2 * width * height)
        .map(|i| ((i % 97) as f32 - 48.0) * 0.640625)
        .collect();
    FlowField {
        width,
        height,
        uv,
        valid: None,
    }
}

/// Builds an `.npy` file by hand (format version `major`) around `data`.
fn npy_bytes(major: u8, header: &str, data: &[u8]) -> Vec<u8> {
    let mut bytes = b"\x93NUMPY".to_vec();
    bytes.extend([major, 0]);
    let mut header = header.to_string();
    let prefix = if major == 1 { 10 } else { 12 };
    while !(prefix + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    if major == 1 {
        bytes.extend((header.len() as u16).to_le_bytes());
    } else {
        bytes.extend((header.len() as u32).to_le_bytes());
    }
    bytes.extend(header.as_bytes());
    bytes.extend(data);
    bytes
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn assert_error_names(
    result: Result<FlowField, vadscope::sequence::SequenceError>,
    path: &Path,
    needle: &str,
) {
    let message = result.expect_err("malformed input must fail").to_string();
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    assert!(
        message.contains(name),
        "error does not name the file: {message}"
    );
    assert!(
        message.contains(needle),
        "error does not say {needle:?}: {message}"
    );
}

#[test]
fn kitti_png_round_trip_is_exact_on_64th_pixels_and_keeps_invalid() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("OPTICAL_FLOW_3.png");
    let mut flow = ramp_flow(13, 7);
    let mut valid = vec![true; 13 * 7];
    valid[20] = false;
    flow.valid = Some(valid.clone());
    write_kitti_png(&path, &flow).expect("writes");
    let back = read_kitti_png(&path).expect("reads");
    assert_eq!((back.width, back.height), (13, 7));
    assert_eq!(back.valid, Some(valid));
    for y in 0..7 {
        for x in 0..13 {
            if back.is_valid(x, y) {
                assert_eq!(back.at(x, y), flow.at(x, y), "pixel ({x}, {y})");
            }
        }
    }
    assert_eq!(read_flow(&path).expect("by extension"), back);
}

#[test]
fn kitti_png_rounds_to_a_64th_and_all_valid_reads_as_none() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("f.png");
    let flow = FlowField {
        width: 2,
        height: 1,
        uv: vec![0.3, -7.01, 100.0, 0.0],
        valid: None,
    };
    write_flow(&path, &flow).expect("writes");
    let back = read_kitti_png(&path).expect("reads");
    assert!(back.valid.is_none());
    for (a, b) in back.uv.iter().zip(&flow.uv) {
        assert!((a - b).abs() <= 1.0 / 128.0, "{a} vs {b}");
    }
}

#[test]
fn kitti_png_of_wrong_bit_depth_is_rejected() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("eight_bit_flow.png");
    image::RgbImage::new(4, 4).save(&path).expect("8-bit png");
    assert_error_names(read_kitti_png(&path), &path, "16-bit RGB");
    let grey = dir.path().join("grey16.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(4, 4)
        .save(&grey)
        .expect("16-bit grey png");
    assert_error_names(read_kitti_png(&grey), &grey, "16-bit RGB");
    let garbage = dir.path().join("garbage.png");
    std::fs::write(&garbage, b"not a png at all").expect("write");
    assert_error_names(read_kitti_png(&garbage), &garbage, "decode");
}

#[test]
fn flo_round_trip_on_disk() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("frame.flo");
    let flow = ramp_flow(9, 4);
    write_flo(&path, &flow).expect("writes");
    assert_eq!(
        std::fs::metadata(&path).expect("exists").len(),
        12 + 8 * 9 * 4
    );
    assert_eq!(read_flo(&path).expect("reads"), flow);
    assert_eq!(read_flow(&path).expect("by extension"), flow);
}

#[test]
fn flo_unknown_values_become_invalid_pixels() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("unknown.flo");
    let mut bytes = b"PIEH".to_vec();
    bytes.extend(2i32.to_le_bytes());
    bytes.extend(1i32.to_le_bytes());
    bytes.extend(f32_bytes(&[1.5, -2.0, 1e10, 0.0]));
    std::fs::write(&path, bytes).expect("write");
    let flow = read_flo(&path).expect("reads");
    assert_eq!(flow.valid, Some(vec![true, false]));
    assert_eq!(flow.at(0, 0), [1.5, -2.0]);
    assert_eq!(flow.at(1, 0), [0.0, 0.0]);
}

#[test]
fn malformed_flo_files_name_the_file_and_problem() {
    let dir = tempfile::tempdir().expect("temp dir");
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).expect("write");
        path
    };
    let short = write("short.flo", b"PIEH\x02\0");
    assert_error_names(read_flo(&short), &short, "truncated");

    let mut wrong = b"HEIP".to_vec();
    wrong.extend([1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    let wrong = write("wrong_magic.flo", &wrong);
    assert_error_names(read_flo(&wrong), &wrong, "PIEH");

    let mut cut = b"PIEH".to_vec();
    cut.extend(4i32.to_le_bytes());
    cut.extend(4i32.to_le_bytes());
    cut.extend(f32_bytes(&[0.0; 10]));
    let cut = write("cut.flo", &cut);
    assert_error_names(read_flo(&cut), &cut, "truncated");

    let mut huge = b"PIEH".to_vec();
    huge.extend((-5i32).to_le_bytes());
    huge.extend(i32::MAX.to_le_bytes());
    let huge = write("huge.flo", &huge);
    assert_error_names(read_flo(&huge), &huge, "implausible flow size");

    let missing = dir.path().join("missing.flo");
    assert!(
        read_flo(&missing)
            .expect_err("missing")
            .to_string()
            .contains("missing.flo")
    );
}

#[test]
fn npy_flow_reads_versions_one_and_two() {
    let dir = tempfile::tempdir().expect("temp dir");
    let values: Vec<f32> = (0..3 * 2 * 2).map(|i| i as f32 * 0.5 - 2.0).collect();
    for major in [1u8, 2] {
        let path = dir.path().join(format!("RGB_IMG_7.png.v{major}.npy"));
        let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 2, 2), }";
        std::fs::write(&path, npy_bytes(major, header, &f32_bytes(&values))).expect("write");
        let flow = read_npy(&path).expect("reads");
        assert_eq!((flow.width, flow.height), (2, 3));
        assert_eq!(flow.uv, values);
        assert!(flow.valid.is_none());
        assert_eq!(read_flow(&path).expect("by extension"), flow);
    }
}

#[test]
fn garbage_npy_headers_name_the_file_and_problem() {
    let dir = tempfile::tempdir().expect("temp dir");
    let data = f32_bytes(&[0.0; 8]);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("magic.npy", b"NUMPY\x01\0garbage".to_vec(), "magic"),
        ("version.npy", npy_bytes(9, "{}", &data), "version 9"),
        (
            "dtype.npy",
            npy_bytes(
                1,
                "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 2, 2), }",
                &data,
            ),
            "'<f8'",
        ),
        (
            "bigendian.npy",
            npy_bytes(
                1,
                "{'descr': '>f4', 'fortran_order': False, 'shape': (2, 2, 2), }",
                &data,
            ),
            "'>f4'",
        ),
        (
            "fortran.npy",
            npy_bytes(
                1,
                "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2, 2), }",
                &data,
            ),
            "Fortran",
        ),
        (
            "shape.npy",
            npy_bytes(
                1,
                "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 4), }",
                &data,
            ),
            "shape",
        ),
        (
            "short_data.npy",
            npy_bytes(
                1,
                "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 2, 2), }",
                &data,
            ),
            "needs 48",
        ),
        (
            "dict.npy",
            npy_bytes(1, "{'descr': '<f4', 'fortran", &data),
            "not a dict",
        ),
        (
            "header_len.npy",
            b"\x93NUMPY\x01\0\xff\xff{}".to_vec(),
            "truncated",
        ),
    ];
    for (name, bytes, needle) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).expect("write");
        assert_error_names(read_npy(&path), &path, needle);
    }
}

#[test]
fn unknown_flow_extension_is_an_error() {
    let message = read_flow(Path::new("flow.jpg"))
        .expect_err("unknown")
        .to_string();
    assert!(message.contains("flow.jpg") && message.contains("unknown flow file type"));
}
