//! The one error type of the metrics module: what was compared and what is
//! wrong with it.

/// A metric could not be computed from the given inputs.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MetricsError {
    /// Two images (or an image and a per-pixel buffer) describe different
    /// pixel grids.
    #[error(
        "{what}: size mismatch, expected {expected_width}×{expected_height}, \
         got {found_width}×{found_height}; render both at the same resolution"
    )]
    SizeMismatch {
        /// Which input is wrong.
        what: &'static str,
        /// Width of the grid the input should match.
        expected_width: usize,
        /// Height of the grid the input should match.
        expected_height: usize,
        /// Width of the offending input.
        found_width: usize,
        /// Height of the offending input.
        found_height: usize,
    },
    /// A flat per-pixel buffer does not hold `width · height` entries.
    #[error("{what}: expected {expected} values (one per pixel), got {found}")]
    BufferLength {
        /// Which buffer is wrong.
        what: &'static str,
        /// `width · height`.
        expected: usize,
        /// The buffer's length.
        found: usize,
    },
    /// The image has no pixels, so no mean is defined.
    #[error("{what}: image is empty (0 pixels)")]
    Empty {
        /// Which input is empty.
        what: &'static str,
    },
}

/// `Ok` when `len == width · height`, otherwise [`MetricsError::BufferLength`].
pub(crate) fn check_len(
    what: &'static str,
    len: usize,
    width: usize,
    height: usize,
) -> Result<(), MetricsError> {
    let expected = width.saturating_mul(height);
    if len == expected {
        Ok(())
    } else {
        Err(MetricsError::BufferLength {
            what,
            expected,
            found: len,
        })
    }
}
