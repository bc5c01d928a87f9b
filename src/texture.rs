//! Images: a plain row-major pixel grid, PNG/JPEG/EXR loading and saving, bilinear sampling with
//! the same conventions as a GPU sampler, and a few generated textures.
//!
//! Conventions: pixel (0, 0) is the top-left; rows are stored top row first. Texture
//! coordinates follow OBJ: (u, v) = (0, 0) is the *bottom*-left corner of the image, v grows
//! upwards, and the image repeats with period 1 in u and v.

use std::io::{BufRead, Seek};
use std::path::Path;

use exr::prelude as exrp;
use exr::prelude::{ReadChannels, ReadLayers, WritableImage};

use crate::error::{Error, Result};
use crate::input::{fits, open_input};
use crate::mesh::io::create_parent_dir;

/// An 8-bit RGBA pixel.
pub type Rgba8 = [u8; 4];

/// A `width × height` grid of pixels, row-major, top row first: pixel (x, y) is
/// `pixels[y * width + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T> {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<T>,
}

impl<T: Copy> Image<T> {
    /// An image filled with `value`.
    pub fn new(width: usize, height: usize, value: T) -> Self {
        Image {
            width,
            height,
            pixels: vec![value; width * height],
        }
    }

    /// An image whose pixel (x, y) is `f(x, y)`.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> T) -> Self {
        let pixels = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        Image {
            width,
            height,
            pixels,
        }
    }

    /// Pixel (x, y); panics when outside the image (a programming error, not bad input).
    pub fn get(&self, x: usize, y: usize) -> T {
        self.pixels[self.index(x, y)]
    }

    /// Set pixel (x, y); panics when outside the image.
    pub fn set(&mut self, x: usize, y: usize, value: T) {
        let i = self.index(x, y);
        self.pixels[i] = value;
    }

    fn index(&self, x: usize, y: usize) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        y * self.width + x
    }
}

// ---------------------------------------------------------------------------------------------
// Files

/// Load a PNG or JPEG (format from the file's contents) as 8-bit RGBA. 16-bit images are
/// reduced to 8 bits (`round(x / 257)`), grey and RGB images get opaque alpha.
pub fn load_rgba8(path: &Path) -> Result<Image<Rgba8>> {
    let rgba = open_image(path)?.to_rgba8();
    let (width, height) = (rgba.width() as usize, rgba.height() as usize);
    let pixels = rgba.pixels().map(|p| p.0).collect();
    Ok(Image {
        width,
        height,
        pixels,
    })
}

/// Save an RGBA image as PNG, creating the parent directories.
pub fn save_png(image: &Image<Rgba8>, path: &Path) -> Result<()> {
    create_parent_dir(path)?;
    let size_error = || Error::Image {
        path: path.to_path_buf(),
        message: format!(
            "cannot encode {} pixels as a {}x{} PNG",
            image.pixels.len(),
            image.width,
            image.height
        ),
    };
    let (width, height) = (
        u32::try_from(image.width).map_err(|_| size_error())?,
        u32::try_from(image.height).map_err(|_| size_error())?,
    );
    let raw: Vec<u8> = image.pixels.iter().flatten().copied().collect();
    let buffer = image::RgbaImage::from_raw(width, height, raw).ok_or_else(size_error)?;
    buffer
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| image_error(path, e))
}

/// Load a single-channel float image: PNG (or JPEG) as luminance scaled to [0, 1]
/// (`x / 255` or `x / 65535`; colour images use the Rec. 709 luma of the decoder), or an
/// OpenEXR file (by the `.exr` extension) with its raw values: channel `Y` if present, else the
/// Rec. 709 luminance `0.2126 R + 0.7152 G + 0.0722 B` if R, G, B are present, else `R`, else
/// the first channel (alphabetical order, as EXR stores them).
pub fn load_gray_f32(path: &Path) -> Result<Image<f32>> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        return load_exr_gray(path);
    }
    let luma = open_image(path)?.to_luma32f();
    let (width, height) = (luma.width() as usize, luma.height() as usize);
    Ok(Image {
        width,
        height,
        pixels: luma.into_raw(),
    })
}

/// Write a two-channel (R, G) 32-bit float OpenEXR image, `values` row-major top row first
/// (used for offset maps). Creates the parent directories.
pub fn save_exr_rg(path: &Path, width: usize, height: usize, values: &[[f32; 2]]) -> Result<()> {
    if values.len() != width * height {
        return Err(Error::InvalidArgument(format!(
            "{}: {} values for a {width}x{height} image",
            path.display(),
            values.len()
        )));
    }
    create_parent_dir(path)?;
    let channels = exrp::SpecificChannels::build()
        .with_channel("R")
        .with_channel("G")
        .with_pixel_fn(|pos: exrp::Vec2<usize>| {
            let [r, g] = values[pos.y() * width + pos.x()];
            (r, g)
        });
    exrp::Image::from_channels((width, height), channels)
        .write()
        .to_file(path)
        .map_err(|e| exr_error(path, e))
}

/// Default largest image read, in pixels (16384 × 16384): a 100 000 × 100 000 header is
/// refused before anything is allocated for it. Raise it with the environment variable
/// [`MAX_IMAGE_PIXELS_VARIABLE`] when a real texture or height map is larger.
pub const DEFAULT_MAX_IMAGE_PIXELS: u64 = 1 << 28;

/// Environment variable that overrides [`DEFAULT_MAX_IMAGE_PIXELS`] (a positive integer).
pub const MAX_IMAGE_PIXELS_VARIABLE: &str = "REPARAM_MAX_IMAGE_PIXELS";

/// The pixel limit in force: [`MAX_IMAGE_PIXELS_VARIABLE`] when set to a positive integer,
/// else [`DEFAULT_MAX_IMAGE_PIXELS`].
pub fn max_image_pixels() -> u64 {
    std::env::var(MAX_IMAGE_PIXELS_VARIABLE)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(DEFAULT_MAX_IMAGE_PIXELS)
}

/// Refuse an image whose header declares more than [`max_image_pixels`] pixels, before any
/// pixel memory is reserved. `what` names the part of the file (e.g. an EXR layer).
fn check_image_size(path: &Path, what: &str, width: u64, height: u64) -> Result<()> {
    let limit = max_image_pixels();
    if width.saturating_mul(height) > limit {
        return Err(Error::Image {
            path: path.to_path_buf(),
            message: format!(
                "{what} declares {width}x{height} pixels, more than the limit of {limit}; \
                 if the image is real, raise the limit with {MAX_IMAGE_PIXELS_VARIABLE}=<pixels>"
            ),
        });
    }
    Ok(())
}

/// An image reader over `source` with the format guessed from the contents.
fn guessed<R: BufRead + Seek>(path: &Path, source: R) -> Result<image::ImageReader<R>> {
    image::ImageReader::new(source)
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))
}

/// Decode a PNG or JPEG from an input file: a regular file only ([`open_input`]: a device or a
/// FIFO named as a texture is refused, not read), see [`decode_checked`].
fn open_image(path: &Path) -> Result<image::DynamicImage> {
    let (_, file_bytes) = open_input(path)?;
    decode_checked(path, file_bytes, || {
        let (file, _) = open_input(path)?;
        guessed(path, std::io::BufReader::new(file))
    })
}

/// Decode a PNG or JPEG held in memory (an image embedded in a glTF buffer) with the checks of
/// a file (`decode_checked`); `name` names it in errors.
pub fn decode_image(bytes: &[u8], name: &Path) -> Result<image::DynamicImage> {
    decode_checked(name, bytes.len() as u64, || {
        guessed(name, std::io::Cursor::new(bytes))
    })
}

/// Decode a PNG or JPEG after reading its header alone (`reader` is called twice: for the
/// header, then for the pixels): its declared size is checked against [`max_image_pixels`]
/// and against what the `file_bytes` can hold ([`MAX_EXPANSION`]) first, and the decoder's own
/// allocation limit is set to what that size needs (16 bytes a pixel, 16-bit RGBA), so the
/// limit can be raised past the `image` crate's default of 512 MiB.
fn decode_checked<R: BufRead + Seek>(
    path: &Path,
    file_bytes: u64,
    reader: impl Fn() -> Result<image::ImageReader<R>>,
) -> Result<image::DynamicImage> {
    use image::ImageDecoder;
    let decoder = reader()?.into_decoder().map_err(|e| image_error(path, e))?;
    let (width, height) = decoder.dimensions();
    check_image_size(path, "the header", width.into(), height.into())?;
    check_expansion(
        path,
        "the header",
        (width.into(), height.into()),
        decoder.total_bytes(),
        file_bytes,
        "PNG or JPEG",
    )?;
    drop(decoder);
    let mut reader = reader()?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_image_pixels().saturating_mul(16));
    reader.limits(limits);
    reader.decode().map_err(|e| image_error(path, e))
}

fn image_error(path: &Path, error: image::ImageError) -> Error {
    match error {
        image::ImageError::IoError(e) => Error::io(path, e),
        other => Error::Image {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    }
}

fn exr_error(path: &Path, error: exr::error::Error) -> Error {
    match error {
        exr::error::Error::Io(e) => Error::io(path, e),
        other => Error::Image {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    }
}

/// Read an EXR's headers alone and check every layer's data window against
/// [`max_image_pixels`]: the `exr` crate reserves the whole image before it reads a pixel, so
/// a window of 10⁹ rows (or one with ymin above ymax, which the crate swaps into a huge one)
/// would reserve gigabytes from a few hundred bytes.
fn check_exr_size(path: &Path) -> Result<()> {
    // First: a regular file (the `exr` crate would open a FIFO and wait).
    let file_bytes = file_bytes(path)?;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| exr_error(path, e))?;
    for (k, header) in meta.headers.iter().enumerate() {
        let window = header.data_window();
        let (width, height) = (window.size.width() as u64, window.size.height() as u64);
        let what = format!("layer {k}'s data window");
        check_image_size(path, &what, width, height)?;
        let sample_bytes: u64 = header
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        let decoded = width.saturating_mul(height).saturating_mul(sample_bytes);
        check_expansion(path, &what, (width, height), decoded, file_bytes, "EXR")?;
    }
    Ok(())
}

/// The most an image's decoded samples can take per byte of the file, with 1 MiB of slack:
/// deflate (PNG; EXR's ZIP, ZIPS, PXR24) compresses at most 1032:1 (1376:1 of PXR24's 24-bit
/// samples read back as 32), baseline JPEG a flat 8×8 block to a few bits (≈ 1000:1), EXR's
/// PIZ Huffman runs and RLE far less, B44 ≈ 10:1 at best; 2048 leaves a margin over all of them.
pub const MAX_EXPANSION: u64 = 2048;

/// Refuse an image whose samples (`decoded` bytes, `width × height` pixels) are more than
/// [`MAX_EXPANSION`] times the file's bytes (plus 1 MiB): no compression reaches that, so the
/// header is damaged or the file truncated, and the decoders reserve the whole image before
/// they fail (256 MiB from an 806-byte EXR and from a 54-byte PNG, found by
/// `tests/fuzz_parsers.rs`). `format` names the compression in the message.
fn check_expansion(
    path: &Path,
    what: &str,
    (width, height): (u64, u64),
    decoded: u64,
    file_bytes: u64,
    format: &str,
) -> Result<()> {
    let holdable = file_bytes
        .saturating_mul(MAX_EXPANSION)
        .saturating_add(1 << 20);
    if !fits(decoded, 1, holdable) {
        return Err(Error::Image {
            path: path.to_path_buf(),
            message: format!(
                "{what} declares {width}x{height} pixels ({decoded} bytes of samples), more \
                 than a {file_bytes}-byte file can hold at any {format} compression \
                 ({MAX_EXPANSION}:1); the header is damaged or the file is truncated"
            ),
        });
    }
    Ok(())
}

/// The size of `path` in bytes, when it is a regular file ([`open_input`]).
fn file_bytes(path: &Path) -> Result<u64> {
    open_input(path).map(|(_, size)| size)
}

/// Decode an EXR, containing a panic of the `exr` crate at this boundary.
///
/// `exr` 1.74 asserts on some malformed chunk tables ("line should have been filtered", found
/// by `tests/fuzz_parsers.rs`) instead of returning an error. No check of ours before the call
/// covers that (it is deep in the block layout), so the panic is caught here and becomes an
/// [`Error::Image`] naming the file: a last resort, which still lets the default panic hook
/// print its message to stderr.
fn read_exr(path: &Path) -> Result<exrp::Image<exrp::Layer<exrp::AnyChannels<exrp::FlatSamples>>>> {
    let read = || {
        exrp::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
    };
    match std::panic::catch_unwind(read) {
        Ok(result) => result.map_err(|e| exr_error(path, e)),
        Err(_) => Err(Error::Image {
            path: path.to_path_buf(),
            message: "the EXR decoder failed on malformed block data (the file is damaged); \
                      re-export the image"
                .into(),
        }),
    }
}

fn load_exr_gray(path: &Path) -> Result<Image<f32>> {
    check_exr_size(path)?;
    let image = read_exr(path)?;
    let layer = &image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channel = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .map(|c| c.sample_data.values_as_f32().collect::<Vec<f32>>())
    };
    let pixels = if let Some(y) = channel("Y") {
        y
    } else if let (Some(r), Some(g), Some(b)) = (channel("R"), channel("G"), channel("B")) {
        (0..width * height)
            .map(|i| 0.2126 * r[i] + 0.7152 * g[i] + 0.0722 * b[i])
            .collect()
    } else if let Some(r) = channel("R") {
        r
    } else {
        let first = layer
            .channel_data
            .list
            .first()
            .ok_or_else(|| Error::Image {
                path: path.to_path_buf(),
                message: "the EXR layer has no channels".into(),
            })?;
        first.sample_data.values_as_f32().collect()
    };
    Ok(Image {
        width,
        height,
        pixels,
    })
}

// ---------------------------------------------------------------------------------------------
// Sampling

/// Bilinear sample of `image` at texture coordinate `uv`, each channel in 0..=255 as f64.
///
/// With REPEAT addressing and the OBJ origin (bottom-left): texture space `s = u − ⌊u⌋`,
/// `t = 1 − (v − ⌊v⌋)`; pixel coordinates `x = s W − 0.5`, `y = t H − 0.5` (texel centres at
/// half-integers); with `x₀ = ⌊x⌋`, `fx = x − x₀` (same for y), the result is
/// `(1−fx)(1−fy) T(x₀, y₀) + fx (1−fy) T(x₀+1, y₀) + (1−fx) fy T(x₀, y₀+1) + fx fy T(x₀+1, y₀+1)`
/// with texel indices taken modulo W and H.
///
/// This is what a wgpu sampler computes for an `Rgba8Unorm` texture (rows uploaded top row
/// first) with `Linear` min/mag filtering, `Repeat` address modes and no mipmaps, sampled at
/// `(u, 1 − v)` — up to the GPU's reduced filtering precision (typically 8 fractional bits
/// for the weights), and ×255. An empty image samples as 0.
pub fn sample_bilinear(image: &Image<Rgba8>, uv: [f64; 2]) -> [f64; 4] {
    sample_bilinear_with(image, uv, |f| f)
}

/// The texel-space point that [`sample_bilinear`] filters at for `uv`: `(s W − ½, t H − ½)`
/// with `s = u − ⌊u⌋`, `t = 1 − (v − ⌊v⌋)` (texel centres at integers).
pub fn texel_coordinates(image: &Image<Rgba8>, uv: [f64; 2]) -> [f64; 2] {
    let s = uv[0] - uv[0].floor();
    let t = 1.0 - (uv[1] - uv[1].floor());
    [s * image.width as f64 - 0.5, t * image.height as f64 - 0.5]
}

/// [`sample_bilinear`] with each of the two filter fractions passed through `fraction` first:
/// the identity for the reference; a rounding to `2^-bits` for a GPU sampler whose filter
/// weights have `bits` bits (Vulkan's `subTexelPrecisionBits`, at least 4), as
/// `twin::bpm_render` models one.
pub fn sample_bilinear_with(
    image: &Image<Rgba8>,
    uv: [f64; 2],
    fraction: impl Fn(f64) -> f64,
) -> [f64; 4] {
    if image.width == 0 || image.height == 0 {
        return [0.0; 4];
    }
    let [x, y] = texel_coordinates(image, uv);
    let (x0, fx) = texel_and_fraction(x, image.width);
    let (y0, fy) = texel_and_fraction(y, image.height);
    let (fx, fy) = (fraction(fx), fraction(fy));
    let (x1, y1) = ((x0 + 1) % image.width, (y0 + 1) % image.height);
    let corners = [
        (image.get(x0, y0), (1.0 - fx) * (1.0 - fy)),
        (image.get(x1, y0), fx * (1.0 - fy)),
        (image.get(x0, y1), (1.0 - fx) * fy),
        (image.get(x1, y1), fx * fy),
    ];
    let mut result = [0.0; 4];
    for (texel, weight) in corners {
        for c in 0..4 {
            result[c] += weight * texel[c] as f64;
        }
    }
    result
}

/// For a pixel coordinate `x` (texel centres at integers here), the texel `⌊x⌋ mod size` and
/// the fraction `x − ⌊x⌋`. Non-finite input gives texel 0, fraction 0.
fn texel_and_fraction(x: f64, size: usize) -> (usize, f64) {
    if !x.is_finite() {
        return (0, 0.0);
    }
    let floor = x.floor();
    let texel = (floor as i64).rem_euclid(size as i64) as usize;
    (texel, x - floor)
}

// ---------------------------------------------------------------------------------------------
// Generated textures

/// A `size × size` black-and-white checkerboard of `cells × cells` squares (at least 1),
/// the top-left square white.
pub fn checker(size: usize, cells: usize) -> Image<Rgba8> {
    let cells = cells.max(1);
    Image::from_fn(size, size, |x, y| {
        let (cx, cy) = (x * cells / size, y * cells / size);
        if (cx + cy) % 2 == 0 {
            [255, 255, 255, 255]
        } else {
            [0, 0, 0, 255]
        }
    })
}

/// A `size × size` UV test texture: 16 × 16 cells whose colour encodes their position (red
/// grows with u, green with v, blue alternates like a checkerboard), separated by dark lines
/// every 1/16 (bolder every 1/4). Distortion and seams show as bent or broken lines.
pub fn uv_grid_texture(size: usize) -> Image<Rgba8> {
    const CELLS: usize = 16;
    Image::from_fn(size, size, |x, y| {
        let u = (x as f64 + 0.5) / size as f64;
        let v = 1.0 - (y as f64 + 0.5) / size as f64;
        let (cell_u, cell_v) = ((u * CELLS as f64) as usize, (v * CELLS as f64) as usize);
        match grid_line_weight(x, y, size, CELLS) {
            2 => [20, 20, 20, 255],
            1 => [70, 70, 70, 255],
            _ => {
                let level = |cell: usize| (60 + 180 * cell / (CELLS - 1)) as u8;
                let blue = if (cell_u + cell_v) % 2 == 0 { 200 } else { 120 };
                [level(cell_u), level(cell_v), blue, 255]
            }
        }
    })
}

/// For pixel (x, y) of a `size`-pixel texture with `cells` cells per side: 2 on a bold line
/// (every 4 cells, 4 pixels wide up to 1024 pixels), 1 on a thin line (every cell, 2 pixels
/// wide), 0 elsewhere. Line widths grow with the image size beyond 1024 pixels.
fn grid_line_weight(x: usize, y: usize, size: usize, cells: usize) -> u8 {
    let scale = (size as f64 / 1024.0).max(1.0);
    // distance (pixels) from the pixel centre to the nearest line of the given period (cells)
    let distance = |p: usize, period_cells: usize| {
        let period = size as f64 * period_cells as f64 / cells as f64;
        let centre = p as f64 + 0.5;
        (centre - (centre / period).round() * period).abs()
    };
    let near = |period_cells, width| {
        distance(x, period_cells) < width || distance(y, period_cells) < width
    };
    if near(4, 2.0 * scale) {
        2
    } else if near(1, 1.0 * scale) {
        1
    } else {
        0
    }
}

/// The images placed left to right, top-aligned, `gap` pixels apart, on white. The height is
/// that of the tallest image; no images give an empty image.
pub fn side_by_side(images: &[&Image<Rgba8>], gap: usize) -> Image<Rgba8> {
    let width =
        images.iter().map(|i| i.width).sum::<usize>() + gap * images.len().saturating_sub(1);
    let height = images.iter().map(|i| i.height).max().unwrap_or(0);
    let mut out = Image::new(width, height, [255, 255, 255, 255]);
    let mut left = 0;
    for image in images {
        for y in 0..image.height {
            let row = &image.pixels[y * image.width..(y + 1) * image.width];
            out.pixels[y * width + left..y * width + left + image.width].copy_from_slice(row);
        }
        left += image.width + gap;
    }
    out
}
