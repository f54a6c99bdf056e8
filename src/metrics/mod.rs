//! Image metrics on linear float images.
