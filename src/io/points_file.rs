//! The compact form of a capture file's raw profiles: one gzip-compressed NPY array beside the
//! JSON (`NAME.points.npy.gz`), float32 of shape (3, rows, width): the planes x_mm, z_mm and
//! intensity, NaN where a column has no point. Planes rather than (x, z, i) triples because each
//! plane's neighbours are alike and deflate finds that; float32 because a profiler's resolution
//! (1 um at best) is far above its rounding (about 20 nm at 300 mm). numpy reads it with
//! `np.load(gzip.open(path))`. Written by hand over npyz and flate2: no crate stores a ragged
//! list of optional points, and this layout keeps the file a plain NPY any tool can open.

use super::FormatError;
use flate2::Compression;
use flate2::read::GzDecoder;
use flate2::write::GzEncoder;
use npyz::WriterBuilder;
use std::io::Read;

/// One profile's entries: a point (x_mm, z_mm) or none, and its intensity or none.
pub type Row = Vec<(Option<[f64; 2]>, Option<f64>)>;

/// At most this many values in a points file (1 GB of float32): a larger header is refused before
/// anything is allocated.
const MAX_VALUES: u64 = 1 << 28;

/// The bytes of the compressed array of `rows` (each padded with NaN to the longest).
pub fn encode(rows: &[Row]) -> Result<Vec<u8>, FormatError> {
    let width = rows.iter().map(Vec::len).max().unwrap_or(0);
    let n = rows.len();
    let mut planes = vec![f32::NAN; 3 * n * width];
    for (r, row) in rows.iter().enumerate() {
        for (c, (p, i)) in row.iter().enumerate() {
            let at = r * width + c;
            if let Some([x, z]) = p {
                planes[at] = *x as f32;
                planes[n * width + at] = *z as f32;
            }
            if let Some(i) = i {
                planes[2 * n * width + at] = *i as f32;
            }
        }
    }
    let mut out = Vec::new();
    let gz = GzEncoder::new(&mut out, Compression::default());
    // Dropping the encoder (inside the writer) ends the gzip stream.
    npyz::WriteOptions::<f32>::new()
        .default_dtype()
        .shape(&[3, n as u64, width as u64])
        .writer(gz)
        .begin_nd()
        .and_then(|mut w| {
            w.extend(planes.iter().copied())?;
            w.finish()
        })
        .map_err(|e| FormatError::Field {
            file: "the points file".into(),
            at: "array".into(),
            message: format!("cannot encode it: {e}"),
        })?;
    Ok(out)
}

/// The rows of a compressed array read from `reader`; `file` names it in errors. The shape must be
/// (3, rows, width) with at least `min_rows` rows.
pub fn decode<R: Read>(
    reader: R,
    file: &str,
    min_rows: usize,
) -> Result<(Vec<Row>, usize), FormatError> {
    let bad = |m: String| FormatError::Field {
        file: file.to_string(),
        at: "array".into(),
        message: m,
    };
    // Buffered: npyz reads value by value, and each read straight from the decoder cost more
    // than the inflating itself.
    let npy = npyz::NpyFile::new(std::io::BufReader::with_capacity(
        1 << 16,
        GzDecoder::new(reader),
    ))
    .map_err(|e| bad(format!("{e} (want a gzip-compressed NPY array)")))?;
    let shape = npy.shape().to_vec();
    let values: u64 = shape.iter().product();
    if shape.len() != 3 || shape[0] != 3 || (shape[1] as usize) < min_rows || values > MAX_VALUES {
        return Err(bad(format!(
            "shape {shape:?}: want (3, rows, width) with at least {min_rows} rows and at most \
             {MAX_VALUES} values (the planes x_mm, z_mm, intensity)"
        )));
    }
    if npy.order() != npyz::Order::C {
        return Err(bad("Fortran order: save the array in C order".into()));
    }
    let (n, width) = (shape[1] as usize, shape[2] as usize);
    // Read value by value: a header that promises more than the stream holds fails at its end
    // rather than allocating what it promised.
    let mut planes = Vec::new();
    for v in npy
        .data::<f32>()
        .map_err(|e| bad(format!("{e} (the array must hold float32)")))?
    {
        planes.push(v.map_err(|e| bad(format!("{e} after {} values", planes.len())))?);
    }
    if planes.len() as u64 != values {
        return Err(bad(format!(
            "{} values where the shape {shape:?} needs {values}",
            planes.len()
        )));
    }
    let rows = (0..n)
        .map(|r| {
            (0..width)
                .map(|c| {
                    let at = r * width + c;
                    let (x, z, i) = (
                        planes[at],
                        planes[n * width + at],
                        planes[2 * n * width + at],
                    );
                    let point = (x.is_finite() && z.is_finite()).then_some([x as f64, z as f64]);
                    (point, i.is_finite().then_some(i as f64))
                })
                .collect()
        })
        .collect();
    Ok((rows, width))
}
