//! NumPy `.npy` files (format version 1.0): little-endian `float64` (`<f8`), `int64` (`<i8`) and
//! `complex128` (`<c16`) arrays in C order, as `numpy.load` reads them. Written atomically
//! ([`super::atomic_write`]).

use std::io::Write;
use std::path::Path;

use num_complex::Complex64;

use super::MeshIoError;

/// An element type `.npy` files of this module hold.
pub trait NpyElement: Copy {
    /// NumPy's `descr` string.
    const DESCR: &'static str;
    /// Appends the element's little-endian bytes.
    fn put(self, out: &mut Vec<u8>);
}

impl NpyElement for f64 {
    const DESCR: &'static str = "<f8";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl NpyElement for i64 {
    const DESCR: &'static str = "<i8";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl NpyElement for Complex64 {
    const DESCR: &'static str = "<c16";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.re.to_le_bytes());
        out.extend_from_slice(&self.im.to_le_bytes());
    }
}

/// The bytes of an `.npy` file holding `data` with `shape` (C order).
///
/// # Panics
/// If `data.len()` is not the product of `shape` (a caller's bug).
pub fn npy_bytes<T: NpyElement>(shape: &[usize], data: &[T]) -> Vec<u8> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "npy: shape {shape:?} does not hold {} elements",
        data.len()
    );
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape_text = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut header = format!(
        "{{'descr': '{}', 'fortran_order': False, 'shape': {shape_text}, }}",
        T::DESCR
    );
    // Magic (6) + version (2) + header length (2) + header, padded with spaces and ended by a
    // newline to a multiple of 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len() * 16);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for &x in data {
        x.put(&mut out);
    }
    out
}

/// Writes `data` with `shape` to `path` as `.npy` ([`npy_bytes`]).
///
/// # Errors
/// [`MeshIoError::Io`] when the file cannot be written.
pub fn write_npy<T: NpyElement>(
    path: &Path,
    shape: &[usize],
    data: &[T],
) -> Result<(), MeshIoError> {
    let bytes = npy_bytes(shape, data);
    super::atomic_write(path, |w| w.write_all(&bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_is_numpy_s_and_padded_to_64_bytes() {
        let b = npy_bytes(&[2, 3], &[0.0f64; 6]);
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0);
        let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
        assert!(header.starts_with("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }"));
        assert!(header.ends_with('\n'));
        assert_eq!(b.len(), 10 + hlen + 48);
        let one = npy_bytes(&[1], &[Complex64::new(1.0, -2.0)]);
        let hlen = u16::from_le_bytes([one[8], one[9]]) as usize;
        assert!(std::str::from_utf8(&one[10..10 + hlen])
            .unwrap()
            .contains("'<c16'"));
        assert!(std::str::from_utf8(&one[10..10 + hlen])
            .unwrap()
            .contains("(1,)"));
        assert_eq!(&one[10 + hlen..10 + hlen + 8], &1.0f64.to_le_bytes());
        assert_eq!(&one[10 + hlen + 8..], &(-2.0f64).to_le_bytes());
    }
}
