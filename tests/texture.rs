//! Image files: PNG and EXR round trips, typed errors.

use std::path::Path;

use reparam::texture::{load_gray_f32, load_rgba8, save_exr_rg, save_png, Image};
use reparam::Error;

#[test]
fn png_round_trip_creates_parent_directories() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a/b/picture.png");
    let image = Image::from_fn(5, 3, |x, y| [x as u8 * 40, y as u8 * 80, 7, 200 + x as u8]);
    save_png(&image, &path).unwrap();
    assert_eq!(load_rgba8(&path).unwrap(), image);
}

#[test]
fn sixteen_bit_png_loads_as_8_bit_and_as_unit_gray() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gray16.png");
    let values: [u16; 3] = [0, 32896, 65535];
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(3, 1, values.to_vec())
        .unwrap()
        .save(&path)
        .unwrap();
    let rgba = load_rgba8(&path).unwrap();
    assert_eq!(
        rgba.pixels.iter().map(|p| p[0]).collect::<Vec<_>>(),
        [0, 128, 255]
    );
    let gray = load_gray_f32(&path).unwrap();
    for (g, v) in gray.pixels.iter().zip(values) {
        approx::assert_relative_eq!(*g, v as f32 / 65535.0, epsilon = 1e-6);
    }
}

#[test]
fn exr_rg_round_trip_reads_the_red_channel_as_gray() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("maps/offsets.exr");
    let values: Vec<[f32; 2]> = (0..6)
        .map(|i| [i as f32 * 1.5 - 2.0, -(i as f32)])
        .collect();
    save_exr_rg(&path, 3, 2, &values).unwrap();
    let gray = load_gray_f32(&path).unwrap();
    assert_eq!((gray.width, gray.height), (3, 2));
    assert_eq!(gray.pixels, values.iter().map(|v| v[0]).collect::<Vec<_>>());
    assert!(matches!(
        save_exr_rg(&path, 4, 2, &values),
        Err(Error::InvalidArgument(_))
    ));
}

#[test]
fn missing_and_corrupt_images_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.png");
    assert!(matches!(load_rgba8(&missing), Err(Error::Io { path, .. }) if path == missing));
    let corrupt = dir.path().join("corrupt.png");
    std::fs::write(&corrupt, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    assert!(matches!(
        load_rgba8(&corrupt),
        Err(Error::Image { .. } | Error::Io { .. })
    ));
    let not_exr = dir.path().join("bad.exr");
    std::fs::write(&not_exr, b"hello").unwrap();
    assert!(load_gray_f32(&not_exr).is_err());
    assert!(load_gray_f32(Path::new("/nonexistent/x.exr")).is_err());
}
