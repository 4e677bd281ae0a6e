//! Cross-crate and property tests of `has`; the tests live in `tests/tests/`.
#![forbid(unsafe_code)]
