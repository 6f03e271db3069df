//! PNG files: decoding through the `png` crate of image-rs (maintained and fuzzed upstream) and one fast
//! encoder for every PNG tilesynth writes.
//!
//! - [`decode`]: any PNG (bit depths 1 to 16, grey, grey+alpha, RGB, RGBA, palette, Adam7) to 8- or 16-bit
//!   samples. The declared size is checked against a pixel limit before anything is allocated, so a
//!   decompression bomb costs nothing; the inflate writes into a buffer of exactly the declared size (it can
//!   never grow). Every damaged file is an error naming what is wrong: a bad signature, a chunk that fails its
//!   CRC, a duplicate or misplaced IHDR, compressed data that ends before the last row (no zero-filled rows),
//!   corrupt deflate data, an unknown filter type, a missing IEND.
//! - [`encode`]: 8- or 16-bit grey / grey+alpha / RGB / RGBA. The rows are filtered with the adaptive
//!   heuristic of libpng (and Pillow: per row, the filter with the smallest sum of absolute signed residuals),
//!   then cut into bands of about [`BAND_BYTES`] raw bytes that are deflated independently and in parallel,
//!   each ending on a byte-aligned sync-flush (an empty stored block, as pigz does), and joined into one
//!   valid zlib stream with the combined Adler-32 of the whole. The bands depend only on the image size, so
//!   the file is byte-identical at any thread count. The chunks (signature, IHDR, IDAT, IEND, CRCs) are
//!   written by the `png` crate.
//! - [`unfilter`]: the scanline reconstruction of PNG §9 (kept for `_core.png_unfilter`; the decoder above
//!   has its own).

use crate::error::{try_vec, try_with_capacity, Result, TilesynthError};
use rayon::prelude::*;
use std::io::Cursor;

/// Samples of a decoded image, row-major `(height, width, channels)`.
#[derive(Debug, Clone, PartialEq)]
pub enum Samples {
    /// 8-bit samples (bit depths 1, 2, 4 are scaled to 8 as the PNG specification says, by bit replication).
    U8(Vec<u8>),
    /// 16-bit samples, native byte order.
    U16(Vec<u16>),
}

/// A decoded PNG.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA (palettes become RGB, or RGBA with a tRNS chunk).
    pub channels: usize,
    /// The samples.
    pub samples: Samples,
    /// The raw eXIf chunk, if any (for the orientation tag).
    pub exif: Option<Vec<u8>>,
}

/// The header of a PNG: width, height, bit depth and PNG colour type, as declared.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Header {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Bits per sample (1, 2, 4, 8, 16).
    pub bit_depth: u8,
    /// PNG colour type (0 grey, 2 RGB, 3 palette, 4 grey+alpha, 6 RGBA).
    pub color_type: u8,
}

fn bad(what: impl std::fmt::Display) -> TilesynthError {
    TilesynthError::param("png", "file", what.to_string())
}

/// Words for a `png` crate decoding error (its own texts are precise: "CRC error: expected 0x… have 0x…
/// while decoding IHDR chunk", "IHDR chunk appeared twice", ...).
fn describe(e: ::png::DecodingError) -> TilesynthError {
    match e {
        ::png::DecodingError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            bad("truncated PNG: the file ends before the image data is complete")
        }
        ::png::DecodingError::IoError(io) => bad(format!("truncated or unreadable PNG ({io})")),
        ::png::DecodingError::Format(f) => {
            let text = f.to_string();
            if text.contains("image data") || text.contains("IDAT") {
                bad(format!("corrupt or truncated PNG image data ({text})"))
            } else {
                bad(format!("corrupt PNG ({text})"))
            }
        }
        ::png::DecodingError::LimitsExceeded => {
            bad("the PNG's metadata chunks need more memory than the decoder's limit (64 MiB)")
        }
        ::png::DecodingError::Parameter(p) => bad(format!("cannot decode this PNG ({p})")),
    }
}

const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// True if `data` starts with the PNG signature.
pub fn is_png(data: &[u8]) -> bool {
    data.starts_with(&SIGNATURE)
}

/// Reads the header of a PNG (every chunk up to the first IDAT is parsed and CRC-checked, so a second
/// IHDR is an error here already).
pub fn header(data: &[u8]) -> Result<Header> {
    if !is_png(data) {
        return Err(bad("not a PNG file (no PNG signature)"));
    }
    let mut decoder = ::png::Decoder::new(Cursor::new(data));
    decoder.set_ignore_text_chunk(true);
    let info = decoder.read_header_info().map_err(describe)?;
    Ok(Header {
        width: info.width,
        height: info.height,
        bit_depth: info.bit_depth as u8,
        color_type: info.color_type as u8,
    })
}

/// Decodes a whole PNG (the first image of an APNG: its default image), refusing more than `max_pixels`
/// pixels on the declared size before any pixel buffer is allocated. Palettes, bit depths below 8 and tRNS
/// chunks are expanded (a tRNS chunk becomes an alpha channel at every bit depth); 16-bit samples stay 16-bit.
pub fn decode(data: &[u8], max_pixels: u64) -> Result<Decoded> {
    let head = header(data)?;
    let (w, h) = (head.width as u64, head.height as u64);
    if w == 0 || h == 0 {
        return Err(bad(format!("the image is {w}x{h} pixels")));
    }
    if w * h > max_pixels {
        return Err(bad(format!(
            "{w}x{h} = {} pixels exceeds the limit of {max_pixels} pixels",
            w * h
        )));
    }
    let mut decoder = ::png::Decoder::new(Cursor::new(data));
    decoder.set_ignore_text_chunk(true);
    decoder.set_transformations(::png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(describe)?;
    let (ctype, depth) = reader.output_color_type();
    let channels = ctype.samples();
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| bad("the declared size overflows"))?;
    let mut buf = Vec::new();
    buf.try_reserve_exact(size).map_err(|_| {
        bad(format!(
            "cannot allocate {size} bytes for the decoded image"
        ))
    })?;
    buf.resize(size, 0);
    reader.next_frame(&mut buf).map_err(describe)?;
    // the rest of the file: CRCs of the chunks after the image data, and the IEND chunk
    reader.finish().map_err(describe)?;
    let exif = reader.info().exif_metadata.as_ref().map(|e| e.to_vec());
    let n = (w * h) as usize * channels;
    let samples = match depth {
        ::png::BitDepth::Sixteen => {
            let mut out = Vec::new();
            out.try_reserve_exact(n)
                .map_err(|_| bad("cannot allocate the 16-bit samples"))?;
            out.extend(
                buf[..2 * n]
                    .chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]])),
            );
            Samples::U16(out)
        }
        _ => {
            buf.truncate(n);
            Samples::U8(buf)
        }
    };
    Ok(Decoded {
        width: w as usize,
        height: h as usize,
        channels,
        samples,
        exif,
    })
}

/// How hard [`encode`] compresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Deflate level 1 (zlib-rs's "quick" strategy, static Huffman codes), filters scored on samples: the
    /// fastest; on tilesynth outputs about 1.3x Pillow's file size.
    Fast,
    /// Deflate level 2, filters scored on samples (the default): within about 10 % of Pillow's file size
    /// at a fifth of its CPU time or less.
    Default,
    /// Deflate level 9, filters scored on every byte: the smallest files (about Pillow's), the slowest.
    Best,
}

impl Compression {
    /// `"fast"`, `"default"`, `"best"`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "fast" => Ok(Compression::Fast),
            "default" => Ok(Compression::Default),
            "best" => Ok(Compression::Best),
            _ => Err(TilesynthError::param(
                "compression",
                format!("{name:?}"),
                "must be \"fast\", \"default\" or \"best\"",
            )),
        }
    }

    fn level(self) -> u32 {
        match self {
            Compression::Fast => 1,
            Compression::Default => 2,
            Compression::Best => 9,
        }
    }
}

/// Raw bytes per independently deflated band: large enough that each band's deflate set-up (window and hash
/// tables) and the restarted window cost little (256 KiB bands were 10 % slower), small enough for many bands
/// where writing takes long (48 for a 4096x4096 RGB image).
pub const BAND_BYTES: usize = 1 << 20;

/// Encodes `rows` (the image in PNG byte order: `height` rows of `width * channels` samples, 16-bit samples
/// big-endian) as a PNG of `bit_depth` 8 or 16 with `channels` 1 to 4. Parallel over row bands on the
/// current rayon pool; the output does not depend on the number of threads.
pub fn encode(
    rows: &[u8],
    width: usize,
    height: usize,
    channels: usize,
    bit_depth: u8,
    compression: Compression,
) -> Result<Vec<u8>> {
    let color = match channels {
        1 => ::png::ColorType::Grayscale,
        2 => ::png::ColorType::GrayscaleAlpha,
        3 => ::png::ColorType::Rgb,
        4 => ::png::ColorType::Rgba,
        _ => {
            return Err(TilesynthError::param(
                "channels",
                channels,
                "must be 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA)",
            ))
        }
    };
    let depth = match bit_depth {
        8 => ::png::BitDepth::Eight,
        16 => ::png::BitDepth::Sixteen,
        _ => {
            return Err(TilesynthError::param(
                "bit_depth",
                bit_depth,
                "must be 8 or 16",
            ))
        }
    };
    if width == 0 || height == 0 || width > i32::MAX as usize || height > i32::MAX as usize {
        return Err(TilesynthError::shape(
            "image",
            "at least 1x1 and at most 2^31-1 pixels a side",
            format!("{height}x{width}"),
        ));
    }
    let bpp = channels * bit_depth as usize / 8;
    let row_bytes = width
        .checked_mul(bpp)
        .ok_or_else(|| TilesynthError::param("width", width, "row size overflows"))?;
    let expected = row_bytes
        .checked_mul(height)
        .ok_or_else(|| TilesynthError::param("height", height, "image size overflows"))?;
    if rows.len() != expected {
        return Err(TilesynthError::param(
            "rows",
            format!("{} bytes", rows.len()),
            format!("expected height x width x channels x bytes per sample = {expected}"),
        ));
    }
    let stream = zlib_stream(rows, row_bytes, bpp, compression)?;
    let mut out = try_with_capacity("image", stream.len() + 128)?;
    {
        let mut enc = ::png::Encoder::new(&mut out, width as u32, height as u32);
        enc.set_color(color);
        enc.set_depth(depth);
        let mut writer = enc
            .write_header()
            .map_err(|e| bad(format!("PNG header: {e}")))?;
        for piece in stream.chunks(1 << 20) {
            writer
                .write_chunk(::png::chunk::IDAT, piece)
                .map_err(|e| bad(format!("PNG image data: {e}")))?;
        }
        writer.finish().map_err(|e| bad(format!("PNG end: {e}")))?;
    }
    Ok(out)
}

/// The zlib stream of the filtered rows: header, independently deflated bands (each ending on a sync
/// flush), an empty final block, the Adler-32 of all filtered bytes.
fn zlib_stream(
    rows: &[u8],
    row_bytes: usize,
    bpp: usize,
    compression: Compression,
) -> Result<Vec<u8>> {
    let height = rows.len() / row_bytes.max(1);
    let band_rows = (BAND_BYTES / (row_bytes + 1)).clamp(1, height.max(1));
    let bands: Vec<(usize, usize)> = (0..height)
        .step_by(band_rows)
        .map(|y0| (y0, (y0 + band_rows).min(height)))
        .collect();
    let level = compression.level();
    let parts: Vec<(Vec<u8>, u32, usize)> = bands
        .par_iter()
        .map(|&(y0, y1)| {
            let filtered = filter_band(
                rows,
                row_bytes,
                bpp,
                y0,
                y1,
                compression != Compression::Best,
            );
            let adler = adler(&filtered);
            let packed = deflate_sync(&filtered, level);
            (packed, adler, filtered.len())
        })
        .collect();
    let total: usize = parts.iter().map(|p| p.0.len()).sum();
    let mut out = Vec::new();
    out.try_reserve_exact(total + 8)
        .map_err(|_| bad("cannot allocate the compressed image"))?;
    // CMF 0x78 (deflate, 32 KiB window); FLG with the level hint and the check bits
    out.extend_from_slice(match compression {
        Compression::Fast => &[0x78, 0x01],
        Compression::Default => &[0x78, 0x5e],
        Compression::Best => &[0x78, 0xda],
    });
    let mut adler = 1u32;
    for (packed, a, len) in &parts {
        out.extend_from_slice(packed);
        adler = adler32_combine(adler, *a, *len);
    }
    // a final, empty block with fixed codes: BFINAL 1, BTYPE 01, end-of-block (7 zero bits)
    out.extend_from_slice(&[0x03, 0x00]);
    out.extend_from_slice(&adler.to_be_bytes());
    Ok(out)
}

/// Raw deflate of `data` ending on a sync flush (byte-aligned, not final), so bands can be concatenated.
fn deflate_sync(data: &[u8], level: u32) -> Vec<u8> {
    let mut c = flate2::Compress::new(flate2::Compression::new(level), false);
    let mut out = Vec::with_capacity(data.len() / 2 + 64);
    loop {
        let consumed = c.total_in() as usize;
        let status = c
            .compress_vec(&data[consumed..], &mut out, flate2::FlushCompress::Sync)
            .expect("deflate into a growing buffer cannot fail");
        let done = c.total_in() as usize == data.len() && out.len() < out.capacity();
        if done || status == flate2::Status::StreamEnd {
            break;
        }
        out.reserve(out.capacity().max(4096));
    }
    out
}

/// The Adler-32 of `data`.
fn adler(data: &[u8]) -> u32 {
    let mut h = simd_adler32::Adler32::new();
    h.write(data);
    h.finish()
}

/// zlib's `adler32_combine`: the Adler-32 of `A ++ B` from those of `A` (`a`) and `B` (`b`, `len_b` bytes).
fn adler32_combine(a: u32, b: u32, len_b: usize) -> u32 {
    const BASE: u64 = 65521;
    let rem = (len_b as u64) % BASE;
    let a1 = (a & 0xffff) as u64;
    let a2 = (a >> 16) as u64;
    let b1 = (b & 0xffff) as u64;
    let b2 = (b >> 16) as u64;
    let sum1 = (a1 + b1 + BASE - 1) % BASE;
    let sum2 = (rem * a1 + a2 + b2 + BASE - rem) % BASE;
    (sum1 | (sum2 << 16)) as u32
}

/// Filters rows `y0..y1` (each gets its filter byte), choosing per row the filter with the smallest sum of
/// absolute signed residuals (libpng's heuristic; the previous row of `y0` is the image's, so a band is
/// exactly what a sequential encoder would produce). With `sampled`, rows of at least [`SAMPLED_ROW`] bytes
/// are judged on one block of 64 bytes in every 512 (an encoder's residual at a byte depends only on the
/// raw bytes around it, so any subset can be scored), then filtered once with the winner: about 3x less
/// work than scoring every byte for a file a fraction of a percent larger.
fn filter_band(
    rows: &[u8],
    row_bytes: usize,
    bpp: usize,
    y0: usize,
    y1: usize,
    sampled: bool,
) -> Vec<u8> {
    let mut out = Vec::with_capacity((y1 - y0) * (row_bytes + 1));
    let zero = vec![0u8; row_bytes];
    let mut scratch = vec![0u8; row_bytes];
    for y in y0..y1 {
        let cur = &rows[y * row_bytes..(y + 1) * row_bytes];
        let prev = if y == 0 {
            &zero[..]
        } else {
            &rows[(y - 1) * row_bytes..y * row_bytes]
        };
        let mut best = (u64::MAX, 0u8);
        for k in 0..5u8 {
            let cost = if sampled && row_bytes >= SAMPLED_ROW {
                sampled_cost(k, cur, prev, bpp)
            } else {
                let fused = apply_filter(k, cur, prev, bpp, &mut scratch);
                // the fused u32 sum is exact below 2^24 bytes a row (at most 128 per byte)
                if row_bytes < 1 << 24 {
                    fused as u64
                } else {
                    abs_sum(&scratch)
                }
            };
            if cost < best.0 {
                best = (cost, k);
            }
        }
        out.push(best.1);
        let start = out.len();
        out.resize(start + row_bytes, 0);
        apply_filter(best.1, cur, prev, bpp, &mut out[start..]);
    }
    out
}

/// Rows of at least this many bytes are scored on samples when `sampled` (see [`filter_band`]).
const SAMPLED_ROW: usize = 1024;

/// The sum of residual magnitudes of filter `kind` over one block of 64 bytes in every 512 of the row,
/// from byte `bpp` on.
fn sampled_cost(kind: u8, cur: &[u8], prev: &[u8], bpp: usize) -> u64 {
    const BLOCK: usize = 64;
    const STEP: usize = 512;
    let n = cur.len();
    let mut total = 0u64;
    let mut s = bpp;
    while s < n {
        let e = (s + BLOCK).min(n);
        let (x, a) = (&cur[s..e], &cur[s - bpp..e - bpp]);
        let (b, c) = (&prev[s..e], &prev[s - bpp..e - bpp]);
        let mut acc = 0u32;
        match kind {
            0 => x.iter().for_each(|&v| acc += mag(v)),
            1 => x
                .iter()
                .zip(a)
                .for_each(|(&v, &l)| acc += mag(v.wrapping_sub(l))),
            2 => x
                .iter()
                .zip(b)
                .for_each(|(&v, &u)| acc += mag(v.wrapping_sub(u))),
            3 => x.iter().zip(a).zip(b).for_each(|((&v, &l), &u)| {
                acc += mag(v.wrapping_sub(((l as u16 + u as u16) >> 1) as u8))
            }),
            _ => x
                .iter()
                .zip(a)
                .zip(b)
                .zip(c)
                .for_each(|(((&v, &l), &u), &ul)| {
                    acc += mag(v.wrapping_sub(paeth_branchless(l, u, ul)))
                }),
        }
        total += acc as u64;
        s += STEP;
    }
    total
}

/// Sum of the absolute values of `buf` read as signed bytes (in u32 blocks, so it vectorises).
fn abs_sum(buf: &[u8]) -> u64 {
    buf.chunks(1 << 16)
        .map(|c| {
            c.iter()
                .map(|&b| (b as i8).unsigned_abs() as u32)
                .sum::<u32>() as u64
        })
        .sum()
}

/// |r| of a residual byte read as signed.
#[inline(always)]
fn mag(r: u8) -> u32 {
    (r as i8).unsigned_abs() as u32
}

/// Writes filter `kind`'s residuals of row `cur` (previous row `prev`) into `out` and returns the (wrapping)
/// u32 sum of their magnitudes. Branch-free loops over zipped slices, which the compiler vectorises.
fn apply_filter(kind: u8, cur: &[u8], prev: &[u8], bpp: usize, out: &mut [u8]) -> u32 {
    let n = cur.len();
    let head = bpp.min(n);
    let (out_head, out_tail) = out.split_at_mut(head);
    let mut cost = 0u32;
    match kind {
        0 => {
            for (o, &x) in out.iter_mut().zip(cur) {
                *o = x;
                cost = cost.wrapping_add(mag(x));
            }
        }
        1 => {
            for (o, &x) in out_head.iter_mut().zip(&cur[..head]) {
                *o = x;
                cost = cost.wrapping_add(mag(x));
            }
            for ((o, &x), &a) in out_tail.iter_mut().zip(&cur[head..]).zip(&cur[..n - head]) {
                let r = x.wrapping_sub(a);
                *o = r;
                cost = cost.wrapping_add(mag(r));
            }
        }
        2 => {
            for ((o, &x), &b) in out.iter_mut().zip(cur).zip(prev) {
                let r = x.wrapping_sub(b);
                *o = r;
                cost = cost.wrapping_add(mag(r));
            }
        }
        3 => {
            for ((o, &x), &b) in out_head.iter_mut().zip(&cur[..head]).zip(&prev[..head]) {
                let r = x.wrapping_sub(b >> 1);
                *o = r;
                cost = cost.wrapping_add(mag(r));
            }
            for (((o, &x), &a), &b) in out_tail
                .iter_mut()
                .zip(&cur[head..])
                .zip(&cur[..n - head])
                .zip(&prev[head..])
            {
                let r = x.wrapping_sub(((a as u16 + b as u16) >> 1) as u8);
                *o = r;
                cost = cost.wrapping_add(mag(r));
            }
        }
        _ => {
            for ((o, &x), &b) in out_head.iter_mut().zip(&cur[..head]).zip(&prev[..head]) {
                let r = x.wrapping_sub(b);
                *o = r;
                cost = cost.wrapping_add(mag(r));
            }
            for ((((o, &x), &a), &b), &c) in out_tail
                .iter_mut()
                .zip(&cur[head..])
                .zip(&cur[..n - head])
                .zip(&prev[head..])
                .zip(&prev[..n - head])
            {
                let r = x.wrapping_sub(paeth_branchless(a, b, c));
                *o = r;
                cost = cost.wrapping_add(mag(r));
            }
        }
    }
    cost
}

/// The Paeth predictor without branches (selects), equal to [`paeth`].
#[inline(always)]
fn paeth_branchless(a: u8, b: u8, c: u8) -> u8 {
    let (ia, ib, ic) = (a as i16, b as i16, c as i16);
    let pa = (ib - ic).abs();
    let pb = (ia - ic).abs();
    let pc = (ia + ib - 2 * ic).abs();
    let bc = if pb <= pc { b } else { c };
    if pa <= pb && pa <= pc {
        a
    } else {
        bc
    }
}

/// Undoes the filters of `rows` scanlines of `row_bytes` bytes each (without the filter byte), `bpp` bytes
/// per complete pixel (1..=8; the "left" neighbour of a byte is `bpp` bytes back). `data` holds the rows as
/// stored in the file: one filter-type byte (0 None, 1 Sub, 2 Up, 3 Average, 4 Paeth), then `row_bytes`
/// filtered bytes. Returns the `rows * row_bytes` raw bytes.
pub fn unfilter(data: &[u8], rows: usize, row_bytes: usize, bpp: usize) -> Result<Vec<u8>> {
    if !(1..=8).contains(&bpp) {
        return Err(TilesynthError::param("bpp", bpp, "must be in [1, 8]"));
    }
    let stride = row_bytes
        .checked_add(1)
        .ok_or_else(|| TilesynthError::param("row_bytes", row_bytes, "too large"))?;
    let expected = rows.checked_mul(stride).ok_or_else(|| {
        TilesynthError::param(
            "rows",
            rows,
            format!("rows x (row_bytes + 1) overflows (row_bytes = {row_bytes})"),
        )
    })?;
    if data.len() != expected {
        return Err(TilesynthError::param(
            "data",
            format!("{} bytes", data.len()),
            format!("expected rows x (row_bytes + 1) = {rows} x {stride} = {expected} bytes"),
        ));
    }
    let mut out = try_vec("data", rows * row_bytes, 0u8)?;
    let zero = try_vec("row_bytes", row_bytes, 0u8)?;
    for y in 0..rows {
        let line = &data[y * stride..(y + 1) * stride];
        let (kind, src) = (line[0], &line[1..]);
        let (done, rest) = out.split_at_mut(y * row_bytes);
        let prev: &[u8] = if y == 0 {
            &zero
        } else {
            &done[(y - 1) * row_bytes..]
        };
        let cur = &mut rest[..row_bytes];
        match kind {
            0 => cur.copy_from_slice(src),
            1 => {
                for i in 0..row_bytes {
                    let a = if i >= bpp { cur[i - bpp] } else { 0 };
                    cur[i] = src[i].wrapping_add(a);
                }
            }
            2 => {
                for i in 0..row_bytes {
                    cur[i] = src[i].wrapping_add(prev[i]);
                }
            }
            3 => {
                for i in 0..row_bytes {
                    let a = if i >= bpp { cur[i - bpp] as u16 } else { 0 };
                    cur[i] = src[i].wrapping_add(((a + prev[i] as u16) / 2) as u8);
                }
            }
            4 => {
                for i in 0..row_bytes {
                    let (a, c) = if i >= bpp {
                        (cur[i - bpp], prev[i - bpp])
                    } else {
                        (0, 0)
                    };
                    cur[i] = src[i].wrapping_add(paeth(a, prev[i], c));
                }
            }
            k => {
                return Err(TilesynthError::param(
                    "data",
                    format!("filter type {k} at row {y}"),
                    "PNG filter types are 0 to 4 (corrupt image data)",
                ))
            }
        }
    }
    Ok(out)
}

/// The Paeth predictor of left `a`, up `b`, upper-left `c`.
fn paeth(a: u8, b: u8, c: u8) -> u8 {
    let (ia, ib, ic) = (a as i16, b as i16, c as i16);
    let p = ia + ib - ic;
    let (pa, pb, pc) = ((p - ia).abs(), (p - ib).abs(), (p - ic).abs());
    if pa <= pb && pa <= pc {
        a
    } else if pb <= pc {
        b
    } else {
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(n: usize, seed: u32) -> Vec<u8> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                (x >> 16) as u8
            })
            .collect()
    }

    #[test]
    fn round_trips_every_filter_type() {
        for &(rows, row_bytes, bpp) in &[
            (1, 1, 1),
            (5, 12, 6),
            (7, 32, 8),
            (3, 8, 4),
            (4, 6, 2),
            (3, 3000, 6),
        ] {
            let raw = noise(rows * row_bytes, 12345);
            for k in 0..5u8 {
                let mut f = Vec::new();
                let zero = vec![0u8; row_bytes];
                let mut buf = vec![0u8; row_bytes];
                for y in 0..rows {
                    let prev = if y == 0 {
                        &zero[..]
                    } else {
                        &raw[(y - 1) * row_bytes..y * row_bytes]
                    };
                    apply_filter(
                        k,
                        &raw[y * row_bytes..(y + 1) * row_bytes],
                        prev,
                        bpp,
                        &mut buf,
                    );
                    f.push(k);
                    f.extend_from_slice(&buf);
                }
                assert_eq!(unfilter(&f, rows, row_bytes, bpp).unwrap(), raw);
            }
            for sampled in [false, true] {
                let f = filter_band(&raw, row_bytes, bpp, 0, rows, sampled);
                assert_eq!(unfilter(&f, rows, row_bytes, bpp).unwrap(), raw);
            }
        }
    }

    #[test]
    fn rejects_bad_input_without_panicking() {
        assert!(unfilter(&[0, 1, 2], 1, 2, 0).is_err());
        assert!(unfilter(&[0, 1, 2], 1, 2, 9).is_err());
        assert!(unfilter(&[0, 1], 1, 2, 1).is_err());
        let e = unfilter(&[7, 1, 2], 1, 2, 1).unwrap_err();
        assert!(e.to_string().contains("filter type 7 at row 0"), "{e}");
        assert!(unfilter(&[], usize::MAX, usize::MAX, 1).is_err());
        assert!(unfilter(&[], usize::MAX / 2, 3, 1).is_err());
        assert_eq!(unfilter(&[], 0, 5, 1).unwrap(), Vec::<u8>::new());
        assert_eq!(unfilter(&[0, 0], 2, 0, 1).unwrap(), Vec::<u8>::new());
    }

    #[test]
    fn branchless_paeth_is_paeth() {
        for a in 0..=255u8 {
            for b in (0..=255u8).step_by(3) {
                for c in (0..=255u8).step_by(5) {
                    assert_eq!(paeth_branchless(a, b, c), paeth(a, b, c));
                }
            }
        }
    }

    #[test]
    fn adler_combine_matches_the_whole() {
        let data = noise(100_000, 7);
        for cut in [0, 1, 65521, 70000, 100_000] {
            let (a, b) = data.split_at(cut);
            let whole = adler(&data);
            let combined = adler32_combine(adler(a), adler(b), b.len());
            assert_eq!(whole, combined, "cut {cut}");
        }
    }

    #[test]
    fn encode_decode_round_trip_all_layouts() {
        for &(w, h) in &[(1usize, 1usize), (3, 5), (257, 3), (600, 700)] {
            for channels in 1..=4 {
                for depth in [8u8, 16] {
                    let raw = noise(w * h * channels * depth as usize / 8, (w * h) as u32);
                    for c in [Compression::Fast, Compression::Default, Compression::Best] {
                        let file = encode(&raw, w, h, channels, depth, c).unwrap();
                        let d = decode(&file, u64::MAX).unwrap();
                        assert_eq!((d.width, d.height, d.channels), (w, h, channels));
                        match d.samples {
                            Samples::U8(s) => assert_eq!(s, raw),
                            Samples::U16(s) => {
                                let be: Vec<u8> = s.iter().flat_map(|v| v.to_be_bytes()).collect();
                                assert_eq!(be, raw)
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn encode_is_independent_of_the_thread_count() {
        let raw = noise(1500 * 1000 * 3, 3); // 5 bands
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| encode(&raw, 1500, 1000, 3, 8, Compression::Default).unwrap());
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| encode(&raw, 1500, 1000, 3, 8, Compression::Default).unwrap());
        assert_eq!(one, two);
    }

    #[test]
    fn decode_refuses_damage() {
        let raw = noise(64 * 64 * 3, 1);
        let file = encode(&raw, 64, 64, 3, 8, Compression::Fast).unwrap();
        // truncated anywhere
        for cut in [
            0,
            7,
            20,
            40,
            file.len() / 2,
            file.len() - 13,
            file.len() - 1,
        ] {
            assert!(decode(&file[..cut], u64::MAX).is_err(), "cut {cut}");
        }
        // a flipped byte in the IDAT data fails its CRC
        let mut bad_crc = file.clone();
        bad_crc[60] ^= 0x40;
        let e = decode(&bad_crc, u64::MAX).unwrap_err().to_string();
        assert!(e.to_lowercase().contains("crc"), "{e}");
        // the pixel limit
        let e = decode(&file, 100).unwrap_err().to_string();
        assert!(e.contains("exceeds the limit of 100"), "{e}");
        // a second IHDR
        let mut dup = file[..33].to_vec();
        dup.extend_from_slice(&file[8..33]);
        dup.extend_from_slice(&file[33..]);
        let e = decode(&dup, u64::MAX).unwrap_err().to_string();
        assert!(e.contains("IHDR"), "{e}");
        assert!(decode(b"not a png", u64::MAX).is_err());
    }

    #[test]
    fn encode_rejects_bad_arguments() {
        assert!(encode(&[0; 3], 1, 1, 5, 8, Compression::Fast).is_err());
        assert!(encode(&[0; 3], 1, 1, 3, 12, Compression::Fast).is_err());
        assert!(encode(&[0; 2], 1, 1, 3, 8, Compression::Fast).is_err());
        assert!(encode(&[], 0, 1, 3, 8, Compression::Fast).is_err());
        assert!(Compression::parse("max").is_err());
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::decode;
    use crate::error::HUGE_SIDE;

    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= b as u32;
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }

    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        let crc = crc32(&out[start..]);
        out.extend_from_slice(&crc.to_be_bytes());
    }

    /// A valid PNG header declaring an image that cannot be allocated (2^24 x 2^24 RGBA, under a pixel
    /// limit raised out of the way) is an error, not an abort: the decode buffer is reserved fallibly.
    #[test]
    fn a_declared_image_that_cannot_be_allocated_is_an_error() {
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        let side = (HUGE_SIDE as u32).to_be_bytes();
        let ihdr = [&side[..], &side[..], &[8, 6, 0, 0, 0]].concat();
        chunk(&mut png, b"IHDR", &ihdr);
        chunk(
            &mut png,
            b"IDAT",
            &[0x78, 0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
        );
        chunk(&mut png, b"IEND", &[]);
        let e = decode(&png, u64::MAX).unwrap_err().to_string();
        assert!(e.contains("cannot allocate"), "{e}");
    }
}
