//! Loading a picture as grayscale, refusing huge ones before they are decoded, and supersampling.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use image::metadata::Orientation;
use image::{ColorType, ImageDecoder, ImageFormat, ImageReader};
use rayon::prelude::*;

use stencil_io::plain_io;

use super::error::ToneError;
use crate::limits;
use crate::raster::Gray;

/// Load PNG, JPEG, BMP or TIFF of any colour type as a gray in 0..1 (alpha over white: a
/// transparent pixel of a drawing is paper). An image over `max_pixels`, or whose decoded buffers
/// would need more than `limits::MAX_DECODE_BYTES`, is refused from its header before any buffer
/// is allocated; the buffer is allocated fallibly and decoded straight into gray. A JPEG ending
/// before its end-of-image marker is refused as truncated.
pub fn load_gray(path: &Path, max_pixels: u64) -> Result<Gray, ToneError> {
    let open_err = |source: std::io::Error| ToneError::Open {
        path: path.to_path_buf(),
        source: plain_io(source),
    };
    let (reader, format) = open_picture(path)?;
    let mut decoder = reader.into_decoder().map_err(|e| decode_error(path, e))?;
    // A phone stores a portrait photo sideways with an EXIF tag saying how to turn it; a viewer
    // turns it, and so do we. A tag we cannot read leaves the picture as stored.
    let orientation = decoder.orientation().unwrap_or(Orientation::NoTransforms);
    let (width, height) = decoder.dimensions();
    let need = decode_bytes(path, &decoder, max_pixels)?;
    if format == ImageFormat::Jpeg && !jpeg_is_complete(path).map_err(open_err)? {
        return Err(ToneError::Truncated {
            path: path.to_path_buf(),
            format: "JPEG",
        });
    }
    let out_of_memory = || too_much_memory(path, width, height, need);
    let color = decoder.color_type();
    let decoded = decoder.total_bytes();
    let mut buf: Vec<u8> = Vec::new();
    buf.try_reserve_exact(decoded as usize)
        .map_err(|_| out_of_memory())?;
    buf.resize(decoded as usize, 0);
    decoder
        .read_image(&mut buf)
        .map_err(|e| decode_error(path, e))?;
    let pixels = width as u64 * height as u64;
    let mut data: Vec<f32> = Vec::new();
    data.try_reserve_exact(pixels as usize)
        .map_err(|_| out_of_memory())?;
    to_gray(&buf, color, &mut data);
    drop(buf);
    Ok(oriented(Gray::from_data(width, height, data), orientation))
}

/// How the picture's EXIF orientation turns it, in words (`None` when it is shown as stored), for
/// the note `make` and `check` print: the stencil then matches what a viewer shows, and the
/// person knows why its width and height may be swapped against the file's.
pub fn orientation_note(path: &Path) -> Option<&'static str> {
    let (reader, _) = open_picture(path).ok()?;
    let mut decoder = reader.into_decoder().ok()?;
    Some(match decoder.orientation().ok()? {
        Orientation::NoTransforms => return None,
        Orientation::Rotate90 => "turned 90° clockwise",
        Orientation::Rotate180 => "turned 180°",
        Orientation::Rotate270 => "turned 90° counter-clockwise",
        Orientation::FlipHorizontal => "mirrored left to right",
        Orientation::FlipVertical => "mirrored top to bottom",
        Orientation::Rotate90FlipH => "turned 90° clockwise and mirrored",
        Orientation::Rotate270FlipH => "turned 90° counter-clockwise and mirrored",
    })
}

/// Where an output pixel of a turned picture comes from.
type SourceOf = dyn Fn(usize, usize) -> (usize, usize);

/// `g` turned as an EXIF orientation says (as `DynamicImage::apply_orientation` does: the
/// rotations are clockwise, a flip after a rotation is left to right).
pub(super) fn oriented(g: Gray, o: Orientation) -> Gray {
    let (w, h) = (g.width as usize, g.height as usize);
    // The source pixel of output pixel (x, y) in an output of `ow` columns.
    let (ow, oh, src): (usize, usize, Box<SourceOf>) = match o {
        Orientation::NoTransforms => return g,
        Orientation::Rotate90 => (h, w, Box::new(move |x, y| (y, h - 1 - x))),
        Orientation::Rotate180 => (w, h, Box::new(move |x, y| (w - 1 - x, h - 1 - y))),
        Orientation::Rotate270 => (h, w, Box::new(move |x, y| (w - 1 - y, x))),
        Orientation::FlipHorizontal => (w, h, Box::new(move |x, y| (w - 1 - x, y))),
        Orientation::FlipVertical => (w, h, Box::new(move |x, y| (x, h - 1 - y))),
        Orientation::Rotate90FlipH => (h, w, Box::new(move |x, y| (y, x))),
        Orientation::Rotate270FlipH => (h, w, Box::new(move |x, y| (w - 1 - y, h - 1 - x))),
    };
    let mut data = Vec::with_capacity(g.data.len());
    for y in 0..oh {
        for x in 0..ow {
            let (sx, sy) = src(x, y);
            data.push(g.data[sy * w + sx]);
        }
    }
    Gray::from_data(ow as u32, oh as u32, data)
}

/// The picture's size in pixels as shown (after its EXIF orientation), from its header alone
/// (nothing is decoded): what `make` decides the size on the sheet by before any work (see
/// `crate::fit`).
pub fn picture_size(path: &Path) -> Result<(u32, u32), ToneError> {
    let (reader, _) = open_picture(path)?;
    let mut decoder = reader.into_decoder().map_err(|e| decode_error(path, e))?;
    let (w, h) = decoder.dimensions();
    Ok(
        match decoder.orientation().unwrap_or(Orientation::NoTransforms) {
            Orientation::Rotate90
            | Orientation::Rotate270
            | Orientation::Rotate90FlipH
            | Orientation::Rotate270FlipH => (h, w),
            _ => (w, h),
        },
    )
}

/// Millimetres per pixel as a PNG states it (its `pHYs` chunk in pixels per metre, the same on
/// both axes), from its header alone; `None` for any other picture, or a PNG that states none.
pub fn png_mm_per_px(path: &Path) -> Option<f64> {
    let (file, _) = stencil_io::open_bounded(path, stencil_io::Kind::Picture).ok()?;
    let decoder = png::Decoder::new(BufReader::new(file));
    let reader = decoder.read_info().ok()?;
    let d = reader.info().pixel_dims?;
    (d.unit == png::Unit::Meter && d.xppu == d.yppu && d.xppu > 0)
        .then(|| 1000.0 / f64::from(d.xppu))
}

/// The file opened with its format guessed from its first bytes, if it is one stencil reads
/// (PNG, JPEG, BMP, TIFF), and the decoder's allocations capped at [`limits::MAX_DECODE_BYTES`].
fn open_picture(path: &Path) -> Result<(ImageReader<Box<dyn Source>>, ImageFormat), ToneError> {
    let open_err = |source: std::io::Error| ToneError::Open {
        path: path.to_path_buf(),
        source: plain_io(source),
    };
    let (mut file, _) = stencil_io::open_bounded(path, stencil_io::Kind::Picture)?;
    let source: Box<dyn Source> = match png_without_cicp(&mut file).map_err(open_err)? {
        Some(bytes) => Box::new(std::io::Cursor::new(bytes)),
        None => Box::new(BufReader::new(file)),
    };
    let mut reader = ImageReader::new(source)
        .with_guessed_format()
        .map_err(open_err)?;
    let format = match reader.format() {
        Some(f @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::Bmp | ImageFormat::Tiff)) => {
            f
        }
        other => {
            let detail = match other {
                Some(f) => format!("; it looks like {f:?}, which stencil does not read"),
                None => String::new(),
            };
            return Err(ToneError::UnknownFormat {
                path: path.to_path_buf(),
                detail,
            });
        }
    };
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(limits::MAX_DECODE_BYTES);
    reader.limits(limits);
    Ok((reader, format))
}

/// What a picture is decoded from: the file, or a copy of it in memory.
trait Source: BufRead + std::io::Seek {}
impl<T: BufRead + std::io::Seek> Source for T {}

/// A PNG's bytes without its `cICP` chunks (coding-independent code points: colour metadata for
/// HDR and wide-gamut pictures, which a gray stencil has no use for), or `None` when the file is
/// not a PNG or has none (then it is rewound). The png decoder refuses a `cICP` whose values it
/// does not support as "invalid data", failing the whole picture; a viewer shows it, and so do we.
fn png_without_cicp(file: &mut std::fs::File) -> std::io::Result<Option<Vec<u8>>> {
    use std::io::{Seek, SeekFrom};
    const SIGNATURE: &[u8; 8] = b"\x89PNG\r\n\x1a\n";
    let mut head = [0u8; 8];
    let found = (|| -> std::io::Result<bool> {
        if file.read_exact(&mut head).is_err() || &head != SIGNATURE {
            return Ok(false);
        }
        // Chunk headers only: length and type, then past the data and its CRC.
        loop {
            if file.read_exact(&mut head).is_err() {
                return Ok(false);
            }
            let len = u32::from_be_bytes([head[0], head[1], head[2], head[3]]);
            match &head[4..] {
                b"cICP" => return Ok(true),
                b"IDAT" | b"IEND" => return Ok(false),
                _ => file.seek(SeekFrom::Current(i64::from(len) + 4))?,
            };
        }
    })()?;
    file.seek(SeekFrom::Start(0))?;
    if !found {
        return Ok(None);
    }
    let mut bytes = Vec::new();
    file.read_to_end(&mut bytes)?;
    let mut out = Vec::with_capacity(bytes.len());
    out.extend_from_slice(SIGNATURE);
    let mut at = SIGNATURE.len();
    while at + 8 <= bytes.len() {
        let len = u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
        let end = (at + 12).saturating_add(len as usize).min(bytes.len());
        if &bytes[at + 4..at + 8] != b"cICP" {
            out.extend_from_slice(&bytes[at..end]);
        }
        at = end;
    }
    out.extend_from_slice(&bytes[at..]);
    Ok(Some(out))
}

/// The bytes decoding needs (the decoder's buffer and the gray picture), from the header alone:
/// refused when the picture is empty, over `max_pixels`, or over [`limits::MAX_DECODE_BYTES`].
fn decode_bytes(
    path: &Path,
    decoder: &impl ImageDecoder,
    max_pixels: u64,
) -> Result<u64, ToneError> {
    let (width, height) = decoder.dimensions();
    let pixels = width as u64 * height as u64;
    if pixels == 0 {
        return Err(ToneError::Empty {
            path: path.to_path_buf(),
        });
    }
    if pixels > max_pixels {
        return Err(ToneError::TooLarge {
            path: path.to_path_buf(),
            width,
            height,
            mp: pixels as f64 / 1e6,
            limit_mp: max_pixels as f64 / 1e6,
        });
    }
    let need = decoder
        .total_bytes()
        .saturating_add(pixels.saturating_mul(4));
    if need > limits::MAX_DECODE_BYTES {
        return Err(too_much_memory(path, width, height, need));
    }
    Ok(need)
}

/// Decoding a `width` × `height` picture needs `need` bytes, more than it may.
fn too_much_memory(path: &Path, width: u32, height: u32, need: u64) -> ToneError {
    ToneError::TooMuchMemory {
        path: path.to_path_buf(),
        width,
        height,
        gb: need as f64 / 1e9,
        limit_gb: limits::MAX_DECODE_BYTES as f64 / 1e9,
    }
}

/// Decoded pixels of any colour type as gray in 0..1: Rec. 709 luma, composited over white.
fn to_gray(buf: &[u8], color: ColorType, out: &mut Vec<f32>) {
    let channels = usize::from(color.channel_count());
    let bytes = usize::from(color.bytes_per_pixel()) / channels;
    // One loop per layout, its sizes known to the compiler (a 1 MP photo's conversion took
    // 60 M instructions deciding them per sample).
    match (channels, bytes) {
        (1, 1) => gray_of::<1, 1>(buf, out),
        (2, 1) => gray_of::<2, 1>(buf, out),
        (3, 1) => gray_of::<3, 1>(buf, out),
        (4, 1) => gray_of::<4, 1>(buf, out),
        (1, 2) => gray_of::<1, 2>(buf, out),
        (2, 2) => gray_of::<2, 2>(buf, out),
        (3, 2) => gray_of::<3, 2>(buf, out),
        (4, 2) => gray_of::<4, 2>(buf, out),
        (1, _) => gray_of::<1, 4>(buf, out),
        (2, _) => gray_of::<2, 4>(buf, out),
        (3, _) => gray_of::<3, 4>(buf, out),
        _ => gray_of::<4, 4>(buf, out),
    }
}

/// [`to_gray`] of pixels of `C` channels of `B` bytes each (1: 8-bit, 2: 16-bit, else 32-bit
/// float).
fn gray_of<const C: usize, const B: usize>(buf: &[u8], out: &mut Vec<f32>) {
    // Samples in native byte order, as the decoders write them.
    let sample = move |b: &[u8]| -> f32 {
        match B {
            1 => f32::from(b[0]) / 255.0,
            2 => f32::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0,
            _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
        }
    };
    out.par_extend(buf.par_chunks_exact(C * B).map(move |p| {
        let c = |i: usize| sample(&p[i * B..]);
        let (r, g, b, a) = match C {
            1 => (c(0), c(0), c(0), 1.0),
            2 => (c(0), c(0), c(0), c(1)),
            3 => (c(0), c(1), c(2), 1.0),
            _ => (c(0), c(1), c(2), c(3)),
        };
        let l = 0.2126 * r + 0.7152 * g + 0.0722 * b;
        (l * a + (1.0 - a)).clamp(0.0, 1.0)
    }));
}

/// A decoder's error, worded for a person: a failed allocation or limit says so; a decoding error
/// keeps the decoder's words without the Rust type dumps some decoders put in them.
fn decode_error(path: &Path, e: image::ImageError) -> ToneError {
    match e {
        image::ImageError::Limits(_) => ToneError::DecoderLimit {
            path: path.to_path_buf(),
            limit_gb: limits::MAX_DECODE_BYTES as f64 / 1e9,
        },
        image::ImageError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            ToneError::Decode {
                path: path.to_path_buf(),
                msg: "the file ends too early".to_string(),
            }
        }
        image::ImageError::IoError(source) => ToneError::Open {
            path: path.to_path_buf(),
            source: plain_io(source),
        },
        image::ImageError::Unsupported(e) => ToneError::Unsupported {
            path: path.to_path_buf(),
            msg: without_type_dumps(&e.to_string()),
        },
        e => ToneError::Decode {
            path: path.to_path_buf(),
            msg: without_type_dumps(&e.to_string()),
        },
    }
}

/// `text` with each Rust `Debug` struct dump (`ChunkType { type: IDAT, critical: true, .. }`)
/// replaced by its `type` field when it has one (`IDAT`), else by the type's name.
pub(crate) fn without_type_dumps(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(open) = rest.find(" { ") {
        // The name before the brace: the identifier ending at `open`.
        let head = &rest[..open];
        let name_start = head
            .rfind(|c: char| !(c.is_alphanumeric() || c == '_'))
            .map_or(0, |i| i + 1);
        let name = &head[name_start..];
        // The matching closing brace.
        let mut depth = 0;
        let mut close = None;
        for (i, c) in rest[open + 1..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        close = Some(open + 1 + i);
                        break;
                    }
                }
                _ => {}
            }
        }
        let (Some(close), false) = (close, name.is_empty()) else {
            out.push_str(&rest[..open + 3]);
            rest = &rest[open + 3..];
            continue;
        };
        let body = &rest[open + 3..close];
        let shown = body
            .split(',')
            .find_map(|f| f.trim().strip_prefix("type:"))
            .map_or(name, str::trim);
        out.push_str(&head[..name_start]);
        out.push_str(shown);
        rest = &rest[close + 1..];
    }
    out.push_str(rest);
    out
}

/// Whether a JPEG file reaches its end-of-image marker: the marker segments are followed from the
/// start (their lengths skipped, entropy-coded data scanned for the next marker), so an EOI inside
/// an embedded thumbnail does not count. Streams the file; data after the EOI is ignored.
pub(crate) fn jpeg_is_complete(path: &Path) -> std::io::Result<bool> {
    let mut r = BufReader::new(std::fs::File::open(path)?);
    if (byte(&mut r)?, byte(&mut r)?) != (Some(0xFF), Some(0xD8)) {
        return Ok(false);
    }
    // `pending`: a marker already read by the entropy-data scan.
    let mut pending: Option<u8> = None;
    loop {
        let marker = match pending.take() {
            Some(m) => m,
            None => {
                // A marker: 0xFF (any number of fill bytes), then its code.
                if byte(&mut r)? != Some(0xFF) {
                    return Ok(false);
                }
                match marker_code(&mut r)? {
                    Some(m) => m,
                    None => return Ok(false),
                }
            }
        };
        match marker {
            0xD9 => return Ok(true),
            0x01 | 0xD0..=0xD7 => continue,
            _ => {}
        }
        let (Some(hi), Some(lo)) = (byte(&mut r)?, byte(&mut r)?) else {
            return Ok(false);
        };
        let len = u64::from(u16::from_be_bytes([hi, lo]));
        if len < 2 {
            return Ok(false);
        }
        let skip = len - 2;
        if std::io::copy(&mut (&mut r).take(skip), &mut std::io::sink())? < skip {
            return Ok(false);
        }
        if marker != 0xDA {
            continue;
        }
        match after_entropy_data(&mut r)? {
            Some(m) => pending = Some(m),
            None => return Ok(false),
        }
    }
}

/// The next byte, or `None` at the end of the file.
fn byte(r: &mut impl Read) -> std::io::Result<Option<u8>> {
    let mut b = [0u8];
    Ok(match r.read(&mut b)? {
        0 => None,
        _ => Some(b[0]),
    })
}

/// After a marker's first 0xFF: skip fill bytes (more 0xFF) and return the marker's code, or
/// `None` at the end of the file.
fn marker_code(r: &mut impl Read) -> std::io::Result<Option<u8>> {
    loop {
        match byte(r)? {
            Some(0xFF) => continue,
            other => return Ok(other),
        }
    }
}

/// Entropy-coded data after a start of scan runs to the next marker that is neither a stuffed
/// 0xFF 0x00 nor a restart: that marker's code, or `None` if the file ends first.
fn after_entropy_data(r: &mut BufReader<std::fs::File>) -> std::io::Result<Option<u8>> {
    loop {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            return Ok(None);
        }
        let Some(i) = buf.iter().position(|&b| b == 0xFF) else {
            let n = buf.len();
            r.consume(n);
            continue;
        };
        r.consume(i + 1);
        let Some(m) = marker_code(r)? else {
            return Ok(None);
        };
        if m == 0x00 || (0xD0..=0xD7).contains(&m) {
            continue;
        }
        return Ok(Some(m));
    }
}

/// Upsample by an integer factor with bilinear interpolation (the paper's supersampling: thresholding
/// the smooth upsampled gray gives edges that follow the picture, not its pixel staircase).
pub(crate) fn upsample(gray: &Gray, k: u32) -> Gray {
    if k <= 1 {
        return gray.clone();
    }
    let (w, h) = (gray.width * k, gray.height * k);
    let mut out = Gray::new(w, h, 0.0);
    let kf = k as f32;
    for y in 0..h {
        // Pixel centres: output centre (y + 0.5)/k maps to input coordinate minus half a pixel.
        let sy = (y as f32 + 0.5) / kf - 0.5;
        for x in 0..w {
            let sx = (x as f32 + 0.5) / kf - 0.5;
            out.set(x, y, gray.sample(sx, sy));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each colour type's loop gives the gray of the one-sample definition (Rec. 709 luma of
    /// the samples in native byte order, composited over white), to the bit, on random bytes
    /// (16-bit and float samples of every value, NaN and infinities among the floats).
    #[test]
    fn every_layout_converts_to_the_same_gray() {
        // Every NaN alike: which of two NaN operands a sum keeps is the compiler's choice.
        let bits = |v: f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
        let mut rng = crate::test_rng::Lcg(91);
        for color in [
            ColorType::L8,
            ColorType::La8,
            ColorType::Rgb8,
            ColorType::Rgba8,
            ColorType::L16,
            ColorType::La16,
            ColorType::Rgb16,
            ColorType::Rgba16,
            ColorType::Rgb32F,
            ColorType::Rgba32F,
        ] {
            let bpp = usize::from(color.bytes_per_pixel());
            let buf: Vec<u8> = (0..bpp * 257).map(|_| rng.below(256) as u8).collect();
            let (ch, bytes) = (
                usize::from(color.channel_count()),
                bpp / usize::from(color.channel_count()),
            );
            let want: Vec<u32> = buf
                .chunks_exact(bpp)
                .map(|p| {
                    let c = |i: usize| {
                        let b = &p[i * bytes..];
                        match bytes {
                            1 => f32::from(b[0]) / 255.0,
                            2 => f32::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0,
                            _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
                        }
                    };
                    let (r, g, b, a) = match ch {
                        1 => (c(0), c(0), c(0), 1.0),
                        2 => (c(0), c(0), c(0), c(1)),
                        3 => (c(0), c(1), c(2), 1.0),
                        _ => (c(0), c(1), c(2), c(3)),
                    };
                    let l = 0.2126 * r + 0.7152 * g + 0.0722 * b;
                    bits((l * a + (1.0 - a)).clamp(0.0, 1.0))
                })
                .collect();
            let mut got = Vec::new();
            to_gray(&buf, color, &mut got);
            let got: Vec<u32> = got.into_iter().map(bits).collect();
            assert_eq!(got, want, "{color:?}");
        }
    }

    /// A 40 x 20 JPEG, dark in its top 5 rows, with an EXIF APP1 segment (little-endian TIFF
    /// header, one IFD0 entry: Orientation = `tag`) right after the start-of-image marker, as a
    /// phone writes it.
    fn jpeg_with_orientation(tag: u16) -> Vec<u8> {
        let img =
            image::GrayImage::from_fn(40, 20, |_, y| image::Luma([if y < 5 { 0 } else { 255 }]));
        let mut jpg = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut jpg), ImageFormat::Jpeg)
            .unwrap();
        let mut tiff: Vec<u8> = b"II*\0".to_vec();
        tiff.extend(8u32.to_le_bytes()); // IFD0 right after the header
        tiff.extend(1u16.to_le_bytes()); // one entry
        tiff.extend(0x0112u16.to_le_bytes()); // Orientation
        tiff.extend(3u16.to_le_bytes()); // SHORT
        tiff.extend(1u32.to_le_bytes());
        tiff.extend(tag.to_le_bytes());
        tiff.extend([0, 0]);
        tiff.extend(0u32.to_le_bytes()); // no next IFD
        let mut app1 = b"Exif\0\0".to_vec();
        app1.extend(tiff);
        let mut out = jpg[..2].to_vec();
        out.extend([0xFF, 0xE1]);
        out.extend(((app1.len() + 2) as u16).to_be_bytes());
        out.extend(app1);
        out.extend(&jpg[2..]);
        out
    }

    #[test]
    fn exif_orientation_is_applied_and_said() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("phone.jpg");
        // 6: the camera was turned; the picture is shown turned 90° clockwise.
        std::fs::write(&p, jpeg_with_orientation(6)).unwrap();
        let g = load_gray(&p, 1 << 30).unwrap();
        assert_eq!((g.width, g.height), (20, 40), "width and height swap");
        // The dark top rows are now the right-hand columns.
        let at = |x: u32, y: u32| g.data[(y * g.width + x) as usize];
        assert!(
            at(19, 20) < 0.2 && at(0, 20) > 0.8,
            "{} {}",
            at(19, 20),
            at(0, 20)
        );
        assert_eq!(orientation_note(&p), Some("turned 90° clockwise"));
        // 1 (as stored) and no tag at all: unchanged, nothing said.
        std::fs::write(&p, jpeg_with_orientation(1)).unwrap();
        let g = load_gray(&p, 1 << 30).unwrap();
        assert_eq!((g.width, g.height), (40, 20));
        assert_eq!(orientation_note(&p), None);
        // 3: upside down.
        std::fs::write(&p, jpeg_with_orientation(3)).unwrap();
        let g = load_gray(&p, 1 << 30).unwrap();
        assert!(g.data[(19 * 40) as usize] < 0.2 && g.data[0] > 0.8);
    }

    /// A valid TIFF whose compression (CCITT fax) the decoder does not read is unsupported, with
    /// what to convert to, not "damaged or truncated".
    #[test]
    fn an_unsupported_tiff_is_named_as_such() {
        let img = image::GrayImage::from_fn(16, 16, |x, _| image::Luma([(x * 16) as u8]));
        let mut t = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut t), ImageFormat::Tiff)
            .unwrap();
        assert_eq!(&t[..4], b"II*\0");
        let ifd = u32::from_le_bytes(t[4..8].try_into().unwrap()) as usize;
        let n = u16::from_le_bytes([t[ifd], t[ifd + 1]]) as usize;
        let entry = (0..n)
            .map(|k| ifd + 2 + 12 * k)
            .find(|&e| u16::from_le_bytes([t[e], t[e + 1]]) == 259)
            .expect("a Compression tag");
        t[entry + 8..entry + 10].copy_from_slice(&3u16.to_le_bytes()); // CCITT T.4
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("fax.tif");
        std::fs::write(&p, t).unwrap();
        let e = load_gray(&p, 1 << 30).unwrap_err().to_string();
        assert!(e.contains("not supported") && e.contains("PNG"), "{e}");
        assert!(!e.contains("damaged"), "{e}");
    }

    #[test]
    fn type_dumps_are_cut_from_decoder_messages() {
        assert_eq!(
            without_type_dumps(
                "CRC error: expected 0x1 have 0x2 while decoding ChunkType { type: IDAT, critical: true, private: false } chunk."
            ),
            "CRC error: expected 0x1 have 0x2 while decoding IDAT chunk."
        );
        assert_eq!(
            without_type_dumps("bad Thing { a: Inner { b: 1 } } here"),
            "bad Thing here"
        );
        assert_eq!(without_type_dumps("no dumps { here"), "no dumps { here");
    }

    #[test]
    fn upsample_keeps_size_and_range() {
        let mut g = Gray::new(3, 2, 0.0);
        g.set(2, 1, 1.0);
        let u = upsample(&g, 4);
        assert_eq!((u.width, u.height), (12, 8));
        assert!(u.data.iter().all(|v| (0.0..=1.0).contains(v)));
        assert_eq!(u.get(11, 7), 1.0);
        assert_eq!(u.get(0, 0), 0.0);
    }
}
