//! OpenEXR files through the `exr` crate (pure Rust, BSD-3-Clause, no `unsafe`).
//!
//! - [`read`]: the first layer of a flat (not deep) EXR at its largest resolution level, every channel as
//!   `f32` (half and float samples exactly; 32-bit unsigned integer channels, such as object IDs, converted
//!   to `f32`, exact below 2^24). Channels are ordered R, G, B, A (or Y, A for luminance) when the file has
//!   those names, else in the file's order (sorted by name, as EXR stores them). The declared size is checked
//!   against a pixel limit from the header alone, before any sample is allocated.
//! - [`write`]: `(H, W, C)` samples as one layer of `C` channels named Y / Y,A / R,G,B / R,G,B,A (`c00`, `c01`,
//!   ... for other counts), half or float, ZIP compression (lossless).
//!
//! Why the `exr` crate rather than the `OpenEXR` package of PyPI (ASWF, also BSD-3): it adds no runtime
//! dependency (the package stays one abi3 wheel plus numpy and Pillow; OpenEXR ships a C++ wheel per Python
//! version and platform, several MB each, and changed its Python API in 3.3), it is pure Rust without `unsafe`
//! (fuzzed upstream), it runs without the GIL and reports through the core's one error type like every other
//! codec, and it builds with the rest of the crate (no C++ toolchain for an sdist build). The costs: about
//! 20 s more compile time on these machines and a larger extension (about +1.9 MB unstripped for the png, zlib-rs
//! and exr crates together); the crate is maintained by one main author (releases through 2025).

use crate::error::{probe_alloc, try_collect, Result, TilesynthError};
use ::exr::prelude::*;
use std::io::Cursor;

fn bad(what: impl std::fmt::Display) -> TilesynthError {
    TilesynthError::param("exr", "file", what.to_string())
}

/// A decoded EXR: `(height, width, channels)` samples, row-major, interleaved.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The channel names, in the order of `samples`.
    pub names: Vec<String>,
    /// True if every channel is stored as half floats.
    pub half: bool,
    /// The samples.
    pub samples: Vec<f32>,
}

/// The order of channel names: R, G, B, A, Y first (in that order), then the rest by name.
fn rank(name: &str) -> (usize, String) {
    let known = ["R", "G", "B", "A"];
    match known.iter().position(|k| *k == name) {
        Some(i) => (i, String::new()),
        None if name == "Y" => (0, String::new()),
        None => (5, name.to_string()),
    }
}

/// Decodes the first layer of an EXR file, refusing more than `max_pixels` pixels on its declared size.
pub fn read(data: &[u8], max_pixels: u64) -> Result<Decoded> {
    let meta = ::exr::meta::MetaData::read_from_buffered(Cursor::new(data), false)
        .map_err(|e| bad(format!("not a readable OpenEXR file ({e})")))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| bad("an OpenEXR file without any layer"))?;
    if header.deep {
        return Err(bad("deep OpenEXR data is not supported (flat images only)"));
    }
    let (w, h) = (header.layer_size.x() as u64, header.layer_size.y() as u64);
    for hd in &meta.headers {
        let px = hd.layer_size.x() as u64 * hd.layer_size.y() as u64;
        if px > max_pixels {
            return Err(bad(format!(
                "{}x{} = {px} pixels exceeds the limit of {max_pixels} pixels",
                hd.layer_size.x(),
                hd.layer_size.y()
            )));
        }
    }
    if w == 0 || h == 0 {
        return Err(bad(format!("the image is {w}x{h} pixels")));
    }
    // The decoder allocates the declared size infallibly (one f32 or f16 column per channel), and the
    // interleaved copy below as much again: check that both fit before decoding, so that a file whose
    // declared size cannot be allocated is an error, not an abort.
    let declared = (w as u128) * (h as u128) * (header.channels.list.len().max(1) as u128) * 8;
    probe_alloc(
        "data",
        usize::try_from(declared).map_err(|_| bad("the declared size overflows"))?,
    )
    .map_err(|_| {
        bad(format!(
            "cannot allocate {declared} bytes for the declared {w}x{h} image"
        ))
    })?;
    let image = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(Cursor::new(data))
        .map_err(|e| bad(format!("corrupt or truncated OpenEXR data ({e})")))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.x(), layer.size.y());
    let mut chans: Vec<&AnyChannel<FlatSamples>> = layer.channel_data.list.iter().collect();
    if chans.is_empty() {
        return Err(bad("an OpenEXR layer without channels"));
    }
    chans.sort_by_key(|c| rank(&c.name.to_string()));
    let c = chans.len();
    let n = w * h;
    let mut samples = Vec::new();
    samples
        .try_reserve_exact(n * c)
        .map_err(|_| bad("cannot allocate the decoded image"))?;
    samples.resize(n * c, 0f32);
    let mut half = true;
    for (k, ch) in chans.iter().enumerate() {
        if ch.sample_data.len() != n {
            return Err(bad(format!(
                "channel {} has {} samples, expected {n} (subsampled channels are not supported)",
                ch.name,
                ch.sample_data.len()
            )));
        }
        half &= matches!(ch.sample_data, FlatSamples::F16(_));
        for (i, v) in ch.sample_data.values_as_f32().enumerate() {
            samples[i * c + k] = v;
        }
    }
    Ok(Decoded {
        width: w,
        height: h,
        names: chans.iter().map(|c| c.name.to_string()).collect(),
        half,
        samples,
    })
}

/// The channel names [`write`] uses for `c` channels.
pub fn channel_names(c: usize) -> Vec<String> {
    match c {
        1 => vec!["Y".into()],
        2 => vec!["Y".into(), "A".into()],
        3 => vec!["R".into(), "G".into(), "B".into()],
        4 => vec!["R".into(), "G".into(), "B".into(), "A".into()],
        _ => (0..c).map(|k| format!("c{k:02}")).collect(),
    }
}

/// Encodes `samples` (`height x width x channels`, interleaved) as an EXR file of half (`half`) or float
/// channels, ZIP-compressed.
pub fn write(
    samples: &[f32],
    width: usize,
    height: usize,
    channels: usize,
    half: bool,
) -> Result<Vec<u8>> {
    if width == 0 || height == 0 || channels == 0 {
        return Err(TilesynthError::shape(
            "image",
            "at least 1x1 pixels and 1 channel",
            format!("({height}, {width}, {channels})"),
        ));
    }
    if channels > 1024 {
        return Err(TilesynthError::param(
            "channels",
            channels,
            "at most 1024 channels",
        ));
    }
    let n = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .ok_or_else(|| TilesynthError::param("image", "size", "overflows"))?;
    if samples.len() != n {
        return Err(TilesynthError::param(
            "samples",
            samples.len(),
            format!("expected height x width x channels = {n}"),
        ));
    }
    let names = channel_names(channels);
    // One column per channel, allocated fallibly (the image's size comes from the caller).
    let list: Vec<AnyChannel<FlatSamples>> = names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let column = samples.iter().skip(k).step_by(channels).copied();
            let data = if half {
                FlatSamples::F16(try_collect(
                    "image",
                    n / channels,
                    column.map(f16::from_f32),
                )?)
            } else {
                FlatSamples::F32(try_collect("image", n / channels, column)?)
            };
            Ok(AnyChannel::new(name.as_str(), data))
        })
        .collect::<Result<_>>()?;
    let encoding = Encoding {
        compression: ::exr::compression::Compression::ZIP16,
        ..Encoding::default()
    };
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(list.into()),
    );
    let image = Image::from_layer(layer);
    let mut out = Cursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| bad(format!("cannot encode OpenEXR ({e})")))?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_half_and_float() {
        for c in [1usize, 2, 3, 4, 5] {
            let (w, h) = (7, 3);
            let s: Vec<f32> = (0..w * h * c).map(|i| i as f32 * 0.25 - 3.0).collect();
            for half in [false, true] {
                let file = write(&s, w, h, c, half).unwrap();
                let d = read(&file, u64::MAX).unwrap();
                assert_eq!((d.width, d.height, d.names.len(), d.half), (w, h, c, half));
                assert_eq!(d.names, channel_names(c));
                assert_eq!(d.samples, s); // quarter steps are exact in half
            }
        }
    }

    #[test]
    fn refuses_damage() {
        let s = vec![0.5f32; 64 * 64 * 3];
        let file = write(&s, 64, 64, 3, false).unwrap();
        assert!(read(&file, 100)
            .unwrap_err()
            .to_string()
            .contains("exceeds the limit"));
        for cut in [0, 4, 30, file.len() / 2, file.len() - 1] {
            assert!(read(&file[..cut], u64::MAX).is_err(), "cut {cut}");
        }
        assert!(read(b"not an exr", u64::MAX).is_err());
        assert!(write(&s, 64, 64, 2, false).is_err());
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::{read, write};
    use crate::error::HUGE_SIDE;

    /// A file whose header declares a data window too large to allocate (2^24 x 2^24, under a pixel limit
    /// raised out of the way) is an error before the decoder allocates it, not an abort.
    #[test]
    fn a_declared_image_that_cannot_be_allocated_is_an_error() {
        let mut file = write(&[0.5f32; 4 * 4 * 3], 4, 4, 3, false).unwrap();
        let key = b"dataWindow\0box2i\0";
        let at = file
            .windows(key.len())
            .position(|w| w == key)
            .expect("a dataWindow attribute")
            + key.len()
            + 4; // the attribute size
        let max = (HUGE_SIDE as i32 - 1).to_le_bytes();
        file[at + 8..at + 12].copy_from_slice(&max); // xMax
        file[at + 12..at + 16].copy_from_slice(&max); // yMax
        let e = read(&file, u64::MAX).unwrap_err().to_string();
        assert!(e.contains("cannot allocate"), "{e}");
    }
}
