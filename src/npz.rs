//! NumPy `.npz` archives (zip of `.npy` arrays, stored or deflated): the format of the converted
//! EHM model (`tools/convert_ehm.py`) and of the parity fixtures under `tests/data/`.
//!
//! Only what those files use: little-endian `f4`/`f8`/`i4`/`i8`/`u4`/`u8` and unicode strings,
//! C order. Every error names the file and the array.

use std::collections::HashMap;
use std::io::{Read, Seek};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct NpzError {
    pub file: String,
    pub problem: String,
}

/// One array's elements, widened: floats to f32 (f8 is rounded), integers to i64.
#[derive(Clone, Debug, PartialEq)]
pub enum NpyData {
    F32(Vec<f32>),
    I64(Vec<i64>),
    Str(Vec<String>),
}

#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    pub shape: Vec<usize>,
    pub data: NpyData,
}

/// All arrays of an archive, by name (without `.npy`).
pub struct Npz {
    file: String,
    /// Arrays that failed to parse (unsupported dtype, e.g. pickled objects) keep their error
    /// until they are asked for, so other arrays of the same archive stay readable.
    arrays: HashMap<String, Result<NpyArray, String>>,
}

impl Npz {
    pub fn open(path: &Path) -> Result<Self, NpzError> {
        let file = path.display().to_string();
        let reader = std::fs::File::open(path).map_err(|e| NpzError {
            file: file.clone(),
            problem: e.to_string(),
        })?;
        Self::read(std::io::BufReader::new(reader), &file)
    }

    /// Reads an archive; `file` names it in errors.
    pub fn read(reader: impl Read + Seek, file: &str) -> Result<Self, NpzError> {
        let fail = |problem: String| NpzError {
            file: file.to_owned(),
            problem,
        };
        let mut archive =
            zip::ZipArchive::new(reader).map_err(|e| fail(format!("not a .npz archive: {e}")))?;
        let mut arrays = HashMap::new();
        for i in 0..archive.len() {
            let mut entry = archive
                .by_index(i)
                .map_err(|e| fail(format!("entry {i}: {e}")))?;
            let name = entry.name().map_err(|e| fail(format!("entry {i}: {e}")))?;
            let Some(name) = name.strip_suffix(".npy").map(str::to_owned) else {
                continue;
            };
            // The size the archive claims is a hint, capped: a hostile directory must not
            // allocate what the entry does not hold.
            let mut bytes = Vec::with_capacity(entry.size().min(1 << 26) as usize);
            entry
                .read_to_end(&mut bytes)
                .map_err(|e| fail(format!("{name}: {e}")))?;
            arrays.insert(name, parse_npy(&bytes));
        }
        Ok(Self {
            file: file.to_owned(),
            arrays,
        })
    }

    pub fn file(&self) -> &str {
        &self.file
    }

    pub fn error(&self, problem: impl Into<String>) -> NpzError {
        NpzError {
            file: self.file.clone(),
            problem: problem.into(),
        }
    }

    fn get(&self, name: &str) -> Result<&NpyArray, NpzError> {
        match self.arrays.get(name) {
            Some(Ok(array)) => Ok(array),
            Some(Err(problem)) => Err(self.error(format!("{name}: {problem}"))),
            None => Err(self.error(format!("{name}: missing"))),
        }
    }

    pub fn contains(&self, name: &str) -> bool {
        self.arrays.contains_key(name)
    }

    pub fn shape(&self, name: &str) -> Result<&[usize], NpzError> {
        Ok(&self.get(name)?.shape)
    }

    /// Checks the shape; `None` in `expected` accepts any length on that axis.
    fn shaped(&self, name: &str, expected: &[Option<usize>]) -> Result<&NpyArray, NpzError> {
        let array = self.get(name)?;
        let matches = array.shape.len() == expected.len()
            && array
                .shape
                .iter()
                .zip(expected)
                .all(|(&got, want)| want.is_none_or(|w| w == got));
        if !matches {
            let want: Vec<String> = expected
                .iter()
                .map(|w| w.map_or("any".into(), |w| w.to_string()))
                .collect();
            return Err(self.error(format!(
                "{name}: shape {:?}, expected [{}]",
                array.shape,
                want.join(", ")
            )));
        }
        Ok(array)
    }

    /// A float array of the expected shape (row-major), checked finite; returns (data, shape).
    pub fn f32s(
        &self,
        name: &str,
        expected: &[Option<usize>],
    ) -> Result<(&[f32], &[usize]), NpzError> {
        let array = self.shaped(name, expected)?;
        let NpyData::F32(data) = &array.data else {
            return Err(self.error(format!("{name}: expected floats")));
        };
        if let Some(i) = data.iter().position(|x| !x.is_finite()) {
            return Err(self.error(format!("{name}: element {i} is not finite")));
        }
        Ok((data, &array.shape))
    }

    /// An integer array of the expected shape whose values all lie in `range`.
    pub fn indices(
        &self,
        name: &str,
        expected: &[Option<usize>],
        range: std::ops::Range<i64>,
    ) -> Result<(&[i64], &[usize]), NpzError> {
        let array = self.shaped(name, expected)?;
        let NpyData::I64(data) = &array.data else {
            return Err(self.error(format!("{name}: expected integers")));
        };
        if let Some((i, v)) = data.iter().enumerate().find(|(_, v)| !range.contains(v)) {
            return Err(self.error(format!(
                "{name}: element {i} is {v}, outside {}..{}",
                range.start, range.end
            )));
        }
        Ok((data, &array.shape))
    }

    /// A string scalar (0-d unicode array).
    pub fn string(&self, name: &str) -> Result<&str, NpzError> {
        match &self.get(name)?.data {
            NpyData::Str(s) if s.len() == 1 => Ok(&s[0]),
            _ => Err(self.error(format!("{name}: expected one string"))),
        }
    }
}

/// Parses one `.npy` file (format versions 1 to 3).
pub fn parse_npy(bytes: &[u8]) -> Result<NpyArray, String> {
    let magic = b"\x93NUMPY";
    if bytes.len() < 10 || &bytes[..6] != magic {
        return Err("not an .npy array".into());
    }
    let (header_len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let header = bytes
        .get(start..start + header_len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or("truncated or non-text header")?;
    let descr = header_value(header, "descr").ok_or("header has no descr")?;
    let descr = descr.split(',').next().unwrap_or_default().trim();
    let descr = descr.trim_matches(|c| c == '\'' || c == '"');
    if header_value(header, "fortran_order").is_some_and(|v| v.starts_with("True")) {
        return Err("Fortran order is not supported".into());
    }
    let shape = parse_shape(header_value(header, "shape").ok_or("header has no shape")?)?;
    // Sizes are checked, not trusted: a hostile header must not overflow (found by
    // tests/fuzz.rs).
    let count = shape
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .ok_or_else(|| format!("shape {shape:?} overflows"))?;
    let body = &bytes[start + header_len..];

    if descr.len() < 3 || !descr.is_char_boundary(2) {
        return Err(format!("dtype {descr:?}"));
    }
    let (kind, size) = descr.split_at(2);
    let size: usize = size.parse().map_err(|_| format!("dtype {descr:?}"))?;
    let width = if kind.ends_with('U') {
        size.checked_mul(4)
    } else {
        Some(size)
    };
    if !(kind.starts_with('<') || kind.starts_with('|')) && size > 1 {
        return Err(format!("dtype {descr:?}: only little-endian data"));
    }
    let needed = width.and_then(|w| count.checked_mul(w));
    if needed.is_none_or(|n| body.len() < n) {
        return Err(format!(
            "data is {} bytes, shape {shape:?} of {descr} needs {}",
            body.len(),
            needed.map_or("more than memory holds".into(), |n| n.to_string())
        ));
    }
    let width = width.unwrap_or_default();
    let words = |w: usize| body.chunks_exact(w).take(count);
    let data = match (&kind[1..], size) {
        ("f", 4) => NpyData::F32(
            words(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
        ),
        ("f", 8) => NpyData::F32(
            words(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap_or_default()) as f32)
                .collect(),
        ),
        ("i", 4) => NpyData::I64(
            words(4)
                .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i64)
                .collect(),
        ),
        ("u", 4) => NpyData::I64(
            words(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i64)
                .collect(),
        ),
        ("i", 8) | ("u", 8) => NpyData::I64(
            words(8)
                .map(|b| i64::from_le_bytes(b.try_into().unwrap_or_default()))
                .collect(),
        ),
        ("U", _) => NpyData::Str(
            words(width)
                .map(|b| {
                    b.chunks_exact(4)
                        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                        .take_while(|&c| c != 0)
                        .filter_map(char::from_u32)
                        .collect()
                })
                .collect(),
        ),
        _ => return Err(format!("unsupported dtype {descr:?}")),
    };
    Ok(NpyArray { shape, data })
}

/// The text after `'key':` in the header dict, up to the end of the dict.
fn header_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header.find(&format!("'{key}'"))?;
    Some(
        header[at + key.len() + 2..]
            .trim_start()
            .strip_prefix(':')?
            .trim_start(),
    )
}

fn parse_shape(value: &str) -> Result<Vec<usize>, String> {
    let inner = value
        .strip_prefix('(')
        .and_then(|v| v.split_once(')'))
        .map(|(inner, _)| inner)
        .ok_or("malformed shape")?;
    inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().map_err(|_| format!("malformed shape {value:?}")))
        .collect()
}
