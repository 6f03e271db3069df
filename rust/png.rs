//! PNG scanline unfiltering (PNG specification, §9 "Filtering"), the one sequential step of decoding a PNG.
//!
//! `tilesynth.io.load_image` decodes 16-bit colour PNGs itself, because Pillow reduces 16-bit RGB / RGBA /
//! grey+alpha PNGs to 8 bits: Python parses the chunks and inflates the data (zlib), this undoes the
//! per-row filters, which depend on the previous byte and row and so cannot be vectorised in numpy.

use crate::error::{Result, TilesynthError};

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
    let mut out = vec![0u8; rows * row_bytes];
    let zero = vec![0u8; row_bytes];
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

    /// Filters `raw` rows with the given filter type per row (the encoder side), for round trips.
    fn filter(raw: &[u8], row_bytes: usize, bpp: usize, kinds: &[u8]) -> Vec<u8> {
        let rows = raw.len() / row_bytes;
        let mut out = Vec::new();
        for y in 0..rows {
            let cur = &raw[y * row_bytes..(y + 1) * row_bytes];
            let zero = vec![0u8; row_bytes];
            let prev = if y == 0 {
                &zero[..]
            } else {
                &raw[(y - 1) * row_bytes..y * row_bytes]
            };
            let k = kinds[y % kinds.len()];
            out.push(k);
            for i in 0..row_bytes {
                let a = if i >= bpp { cur[i - bpp] } else { 0 };
                let c = if i >= bpp { prev[i - bpp] } else { 0 };
                let pred = match k {
                    0 => 0,
                    1 => a,
                    2 => prev[i],
                    3 => ((a as u16 + prev[i] as u16) / 2) as u8,
                    _ => paeth(a, prev[i], c),
                };
                out.push(cur[i].wrapping_sub(pred));
            }
        }
        out
    }

    #[test]
    fn round_trips_every_filter_type() {
        let mut x = 12345u32;
        for &(rows, row_bytes, bpp) in &[(1, 1, 1), (5, 12, 6), (7, 32, 8), (3, 8, 4), (4, 6, 2)] {
            let raw: Vec<u8> = (0..rows * row_bytes)
                .map(|_| {
                    x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    (x >> 16) as u8
                })
                .collect();
            for kinds in [&[0u8][..], &[1], &[2], &[3], &[4], &[4, 3, 2, 1, 0]] {
                let f = filter(&raw, row_bytes, bpp, kinds);
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
}
