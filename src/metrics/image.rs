//! [`LinearImage`]: a linear-light RGB float image, the input of every metric.
//!
//! Conventions shared by all metrics in this module:
//! - Pixels are stored row-major, `(0, 0)` top-left, `+y` down (the camera's
//!   pixel convention, `src/camera/stereo.rs`).
//! - Values are scene-referred linear Rec. 709 / sRGB-primaries radiance.
//! - **Non-finite values** (NaN, ±Inf) are replaced by `0` before any metric
//!   ([`LinearImage::sanitized`]); [`LinearImage::non_finite_count`] lets a
//!   report say how many there were. A NaN in the test image therefore counts
//!   as a black pixel against the reference, never as a silent skip.
//! - **Display-referred** metrics (PSNR, SSIM, LDR-FLIP, CPBD) use the
//!   *display* image: each channel clamped to `[0, 1]` (exposure 1, no tone
//!   curve); SSIM its luma ([`LinearImage::display_luma`]), CPBD MATLAB's
//!   `rgb2gray` of its 8-bit channels ([`LinearImage::display_grey_8bit`]).

use super::check::{check_len, MetricsError};

/// Rec. 709 / sRGB luminance weights (ITU-R BT.709-6, item 3.3), the `Y` row
/// of the linear-sRGB → XYZ matrix.
pub const REC709_LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// MATLAB `rgb2gray`'s weights (Rec. 601 luma of the encoded channels,
/// as MATLAB documents them): the grey image CPBD's authors computed from
/// an 8-bit colour image ([`LinearImage::display_grey_8bit`]).
pub const RGB2GRAY: [f32; 3] = [0.2989, 0.5870, 0.1140];

/// A linear-light RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major pixels, `width · height` of them.
    pub rgb: Vec<[f32; 3]>,
}

impl LinearImage {
    /// An image from row-major RGB pixels; errors when `rgb.len() != width · height`.
    pub fn new(width: usize, height: usize, rgb: Vec<[f32; 3]>) -> Result<Self, MetricsError> {
        check_len("rgb pixels", rgb.len(), width, height)?;
        Ok(Self { width, height, rgb })
    }

    /// An image of one colour.
    pub fn filled(width: usize, height: usize, rgb: [f32; 3]) -> Self {
        Self {
            width,
            height,
            rgb: vec![rgb; width * height],
        }
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`.
    pub fn from_fn(
        width: usize,
        height: usize,
        mut f: impl FnMut(usize, usize) -> [f32; 3],
    ) -> Self {
        let mut rgb = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                rgb.push(f(x, y));
            }
        }
        Self { width, height, rgb }
    }

    /// An image from RGBA pixels (e.g. a read-back `R32G32B32A32_SFLOAT`
    /// radiance image); alpha is dropped. Errors when
    /// `rgba.len() != width · height`.
    pub fn from_rgba(rgba: &[[f32; 4]], width: usize, height: usize) -> Result<Self, MetricsError> {
        check_len("rgba pixels", rgba.len(), width, height)?;
        Ok(Self {
            width,
            height,
            rgb: rgba.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        })
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.rgb.len()
    }

    /// `true` when the image has no pixels.
    pub fn is_empty(&self) -> bool {
        self.rgb.is_empty()
    }

    /// Pixel `(x, y)`, or `None` outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<[f32; 3]> {
        if x < self.width && y < self.height {
            self.rgb.get(y * self.width + x).copied()
        } else {
            None
        }
    }

    /// Per-pixel linear luminance `Y = 0.2126 R + 0.7152 G + 0.0722 B`
    /// (Rec. 709 weights, [`REC709_LUMA`]); non-finite inputs give `0`.
    pub fn luminance(&self) -> Vec<f32> {
        self.rgb.iter().map(|&p| luminance(sanitize(p))).collect()
    }

    /// Number of pixels with a non-finite channel value (NaN or ±Inf): a
    /// pixel NaN in all three channels counts once (until session 47 this
    /// counted channel values, so a shader's NaN pixel counted three times).
    pub fn non_finite_count(&self) -> usize {
        self.rgb
            .iter()
            .filter(|p| p.iter().any(|v| !v.is_finite()))
            .count()
    }

    /// A copy with every non-finite channel value replaced by `0`.
    pub fn sanitized(&self) -> LinearImage {
        Self {
            width: self.width,
            height: self.height,
            rgb: self.rgb.iter().map(|&p| sanitize(p)).collect(),
        }
    }

    /// The display image: sanitized, each channel clamped to `[0, 1]`.
    pub fn display(&self) -> LinearImage {
        Self {
            width: self.width,
            height: self.height,
            rgb: self
                .rgb
                .iter()
                .map(|&p| sanitize(p).map(|c| c.clamp(0.0, 1.0)))
                .collect(),
        }
    }

    /// Display luma in `[0, 1]`: the sRGB encoding (IEC 61966-2-1 OETF,
    /// [`srgb_encode`]) of the Rec. 709 luminance of the display image
    /// (channels clamped to `[0, 1]`). This is the grey image SSIM works
    /// on: perceptually roughly uniform, like the 8-bit grey images the
    /// original paper used (CPBD takes [`LinearImage::display_grey_8bit`],
    /// MATLAB's `rgb2gray`, as its authors' code did).
    pub fn display_luma(&self) -> Vec<f32> {
        self.display()
            .rgb
            .iter()
            .map(|&p| srgb_encode(luminance(p)))
            .collect()
    }

    /// Grey levels `0..=255` of the display image as MATLAB's `rgb2gray`
    /// reads its 8-bit sRGB file: each channel clamped to `[0, 1]`,
    /// sRGB-encoded and rounded to 8 bits, then
    /// `round(0.2989 R′ + 0.5870 G′ + 0.1140 B′)` ([`RGB2GRAY`]). CPBD's
    /// input (its authors' MATLAB code works on such a grey image; the
    /// `cpbd` package's PIL `'L'` uses the same Rec. 601 weights, rounding
    /// aside). For grey pixels it is `round(255 · Y′)` of
    /// [`Self::display_luma`]; for saturated colours the two differ (pure
    /// red: 76 against 127).
    pub fn display_grey_8bit(&self) -> Vec<f32> {
        let byte = |c: f32| (255.0 * srgb_encode(c)).round();
        self.display()
            .rgb
            .iter()
            .map(|p| {
                let [r, g, b] = p.map(byte);
                (RGB2GRAY[0] * r + RGB2GRAY[1] * g + RGB2GRAY[2] * b).round()
            })
            .collect()
    }

    /// [`MetricsError::SizeMismatch`] unless `other` has this image's size;
    /// [`MetricsError::Empty`] when it has no pixels.
    pub fn check_same_size(
        &self,
        other: &LinearImage,
        what: &'static str,
    ) -> Result<(), MetricsError> {
        if self.width != other.width || self.height != other.height {
            return Err(MetricsError::SizeMismatch {
                what,
                expected_width: self.width,
                expected_height: self.height,
                found_width: other.width,
                found_height: other.height,
            });
        }
        check_len("reference rgb", self.rgb.len(), self.width, self.height)?;
        check_len(what, other.rgb.len(), other.width, other.height)?;
        if self.is_empty() {
            return Err(MetricsError::Empty { what });
        }
        Ok(())
    }
}

/// Rec. 709 luminance of one linear RGB value.
#[inline]
pub fn luminance(p: [f32; 3]) -> f32 {
    REC709_LUMA[0] * p[0] + REC709_LUMA[1] * p[1] + REC709_LUMA[2] * p[2]
}

/// Non-finite channels → 0.
#[inline]
pub(crate) fn sanitize(p: [f32; 3]) -> [f32; 3] {
    p.map(|c| if c.is_finite() { c } else { 0.0 })
}

/// sRGB OETF (IEC 61966-2-1): linear `[0, 1]` → encoded `[0, 1]`; input is
/// clamped to `[0, 1]`.
#[inline]
pub fn srgb_encode(c: f32) -> f32 {
    let c = if c.is_finite() {
        c.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB EOTF (IEC 61966-2-1): encoded `[0, 1]` → linear `[0, 1]`; input is
/// clamped to `[0, 1]`.
#[inline]
pub fn srgb_decode(c: f32) -> f32 {
    let c = if c.is_finite() {
        c.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn from_rgba_checks_length_and_drops_alpha() {
        let img = LinearImage::from_rgba(&[[1.0, 2.0, 3.0, 4.0]; 6], 3, 2).unwrap();
        assert_eq!(img.get(2, 1), Some([1.0, 2.0, 3.0]));
        assert_eq!(img.get(3, 0), None);
        assert!(matches!(
            LinearImage::from_rgba(&[[0.0; 4]; 5], 3, 2),
            Err(MetricsError::BufferLength {
                expected: 6,
                found: 5,
                ..
            })
        ));
    }

    #[test]
    fn luminance_uses_rec709_and_zeroes_non_finite() {
        let img = LinearImage::new(
            3,
            1,
            vec![
                [1.0, 1.0, 1.0],
                [f32::NAN, 1.0, f32::INFINITY],
                [f32::NAN; 3],
            ],
        )
        .unwrap();
        let y = img.luminance();
        assert!((y[0] - 1.0).abs() < 1e-6);
        assert!((y[1] - 0.7152).abs() < 1e-6);
        assert_eq!(y[2], 0.0);
        // Pixels, not channel values: two pixels hold non-finite values.
        assert_eq!(img.non_finite_count(), 2);
    }

    #[test]
    fn srgb_round_trip_and_display_luma() {
        for i in 0..=20 {
            let c = i as f32 / 20.0;
            assert!((srgb_decode(srgb_encode(c)) - c).abs() < 1e-5);
        }
        let img = LinearImage::new(2, 1, vec![[2.0, 5.0, 9.0], [-1.0, 0.0, 0.0]]).unwrap();
        let l = img.display_luma();
        assert!((l[0] - 1.0).abs() < 1e-6 && l[1] == 0.0);
    }

    /// MATLAB `rgb2gray` of 8-bit sRGB channels, by hand: pure red 255 →
    /// round(0.2989 · 255) = 76, green → round(149.685) = 150, blue →
    /// round(29.07) = 29, white → round(254.9745) = 255; linear 0.5 grey
    /// encodes to 187.5 → 188 in every channel → round(187.98) = 188.
    #[test]
    fn display_grey_is_matlab_rgb2gray_of_the_8_bit_channels() {
        let img = LinearImage::new(
            6,
            1,
            vec![
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [3.0, 2.0, 1.0],
                [0.5, 0.5, 0.5],
                [f32::NAN, -1.0, 0.0],
            ],
        )
        .unwrap();
        assert_eq!(
            img.display_grey_8bit(),
            [76.0, 150.0, 29.0, 255.0, 188.0, 0.0]
        );
        // Rec. 709 luminance before the encoding (display_luma) gives red 127.
        assert_eq!((255.0 * img.display_luma()[0]).round(), 127.0);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = LinearImage::filled(4, 4, [0.0; 3]);
        let b = LinearImage::filled(4, 5, [0.0; 3]);
        assert!(matches!(
            a.check_same_size(&b, "test"),
            Err(MetricsError::SizeMismatch { .. })
        ));
        let e = LinearImage::filled(0, 0, [0.0; 3]);
        assert!(matches!(
            e.check_same_size(&e, "test"),
            Err(MetricsError::Empty { .. })
        ));
    }
}
