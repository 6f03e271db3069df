//! PNG scanline reconstruction (the five filter types of the PNG specification, §9).
//!
//! Pillow decodes 16-bit colour PNGs (RGB, RGBA, grey + alpha) to 8 bits, which would silently throw away the
//! precision of 16-bit exemplars and of 16-bit normal or height maps. The Python layer parses the chunks and
//! inflates the image data with `zlib`; this kernel undoes the per-row filters, the only part that is a
//! sequential per-byte loop (Average and Paeth depend on the byte just reconstructed).

use crate::error::{Result, TilesynthError};

/// Reconstructs filtered PNG scanlines.
///
/// `data` holds `height` rows of `1 + row_bytes` bytes each (the filter type, then the filtered bytes), as
/// inflated from the concatenated IDAT chunks of a non-interlaced image; `bpp` is the number of bytes per
/// complete pixel, rounded up to 1 (PNG's "bpp"). Returns the `height * row_bytes` raw bytes.
pub fn unfilter(data: &[u8], height: usize, row_bytes: usize, bpp: usize) -> Result<Vec<u8>> {
    if bpp == 0 || bpp > 8 {
        return Err(TilesynthError::param("bpp", bpp, "must be in 1..=8"));
    }
    let stride = row_bytes
        .checked_add(1)
        .and_then(|s| s.checked_mul(height).map(|t| (s, t)));
    let (stride, total) = match stride {
        Some(v) => v,
        None => return Err(TilesynthError::param("height", height, "image too large")),
    };
    if data.len() < total {
        return Err(TilesynthError::param(
            "data",
            format!("{} bytes", data.len()),
            format!("truncated: expected {total} bytes ({height} rows of 1 + {row_bytes})"),
        ));
    }
    let mut out = vec![0u8; height * row_bytes];
    for y in 0..height {
        let line = &data[y * stride..(y + 1) * stride];
        let (kind, src) = (line[0], &line[1..]);
        let (done, rest) = out.split_at_mut(y * row_bytes);
        let cur = &mut rest[..row_bytes];
        let prev: &[u8] = if y > 0 {
            &done[(y - 1) * row_bytes..]
        } else {
            &[]
        };
        let up = |i: usize| -> u8 {
            if prev.is_empty() {
                0
            } else {
                prev[i]
            }
        };
        match kind {
            0 => cur.copy_from_slice(src),
            1 => {
                for i in 0..row_bytes {
                    let left = if i >= bpp { cur[i - bpp] } else { 0 };
                    cur[i] = src[i].wrapping_add(left);
                }
            }
            2 => {
                for i in 0..row_bytes {
                    cur[i] = src[i].wrapping_add(up(i));
                }
            }
            3 => {
                for i in 0..row_bytes {
                    let left = if i >= bpp { cur[i - bpp] as u16 } else { 0 };
                    cur[i] = src[i].wrapping_add(((left + up(i) as u16) / 2) as u8);
                }
            }
            4 => {
                for i in 0..row_bytes {
                    let a = if i >= bpp { cur[i - bpp] } else { 0 };
                    let b = up(i);
                    let c = if i >= bpp { up(i - bpp) } else { 0 };
                    cur[i] = src[i].wrapping_add(paeth(a, b, c));
                }
            }
            k => {
                return Err(TilesynthError::param(
                    "data",
                    format!("filter type {k} in row {y}"),
                    "not a PNG filter type (0-4): the file is corrupt",
                ))
            }
        }
    }
    Ok(out)
}

/// The Paeth predictor of the PNG specification.
#[inline]
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

    /// Filters `raw` rows with the given type per row (the encoder side, written from the specification).
    #[allow(clippy::needless_range_loop)]
    fn filter(raw: &[u8], height: usize, row_bytes: usize, bpp: usize, kinds: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for y in 0..height {
            let cur = &raw[y * row_bytes..(y + 1) * row_bytes];
            let prev = |i: usize| {
                if y > 0 {
                    raw[(y - 1) * row_bytes + i]
                } else {
                    0
                }
            };
            let left = |i: usize| if i >= bpp { cur[i - bpp] } else { 0 };
            let ul = |i: usize| if i >= bpp && y > 0 { prev(i - bpp) } else { 0 };
            let k = kinds[y % kinds.len()];
            out.push(k);
            for i in 0..row_bytes {
                let pred = match k {
                    0 => 0,
                    1 => left(i),
                    2 => prev(i),
                    3 => ((left(i) as u16 + prev(i) as u16) / 2) as u8,
                    _ => paeth(left(i), prev(i), ul(i)),
                };
                out.push(cur[i].wrapping_sub(pred));
            }
        }
        out
    }

    #[test]
    fn round_trips_every_filter() {
        let mut s = 7u64;
        for (height, width, bpp) in [(1, 1, 1), (5, 7, 6), (9, 4, 8), (3, 11, 2), (6, 6, 3)] {
            let row_bytes = width * bpp;
            let raw: Vec<u8> = (0..height * row_bytes)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                    (s >> 56) as u8
                })
                .collect();
            for kinds in [&[0u8][..], &[1], &[2], &[3], &[4], &[0, 1, 2, 3, 4]] {
                let f = filter(&raw, height, row_bytes, bpp, kinds);
                assert_eq!(unfilter(&f, height, row_bytes, bpp).unwrap(), raw);
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        assert!(unfilter(&[0, 1, 2], 2, 2, 1).is_err());
        let e = unfilter(&[9, 1, 2], 1, 2, 1).unwrap_err();
        assert!(e.to_string().contains("filter type 9"), "{e}");
        assert!(unfilter(&[0, 1], 1, 1, 0).is_err());
        assert!(unfilter(&[], usize::MAX, usize::MAX, 1).is_err());
    }
}
